#include "omnipoint/camera/camera.h"

#include <ATen/ATen.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace omnipoint::camera {

Camera::Camera(const std::string& model, int64_t width, int64_t height, std::vector<double> params)
    : model_(&find_camera_model(model)),
      model_name_(model),
      width_(width),
      height_(height),
      params_(std::move(params)) {
  if (width_ <= 0 || height_ <= 0) {
    std::ostringstream text;
    text << model_name_ << ": image size must be positive, got " << width_ << "x" << height_;
    throw std::invalid_argument(text.str());
  }
  if (!model_->accepts_param_count(params_.size())) {
    std::ostringstream text;
    text << model_name_ << " expects " << model_->expected_params() << ", got " << params_.size();
    throw std::invalid_argument(text.str());
  }
  for (std::size_t i = 0; i < params_.size(); ++i) {
    if (!std::isfinite(params_[i])) {
      std::ostringstream text;
      text << model_name_ << ": parameter " << i + 1 << " is not finite (" << params_[i]
           << "); expects " << model_->expected_params();
      throw std::invalid_argument(text.str());
    }
  }
  model_->check_params(params_, size());
}

at::Tensor Camera::params_tensor(at::TensorOptions options) const {
  return at::tensor(params_, at::TensorOptions().dtype(at::kDouble)).to(options);
}

namespace {

void require_floating(const at::Tensor& input, const char* what) {
  if (!at::isFloatingType(input.scalar_type())) {
    throw std::invalid_argument(std::string(what) +
                                " must be a floating-point tensor (float32 or float64), got " +
                                std::string(c10::toString(input.scalar_type())));
  }
}

}  // namespace

Rays Camera::unproject(const at::Tensor& pixels) const {
  require_floating(pixels, "Camera::unproject: pixels");
  if (pixels.dim() < 1 || pixels.size(-1) != 2) {
    throw std::invalid_argument("Camera::unproject: pixels must have shape (..., 2), got " +
                                std::to_string(pixels.dim() ? pixels.size(-1) : 0) +
                                " in the last dimension");
  }
  return model_->unproject(params_tensor(pixels.options()), size(), pixels);
}

Pixels Camera::project(const at::Tensor& points) const {
  require_floating(points, "Camera::project: points");
  if (points.dim() < 1 || points.size(-1) != 3) {
    throw std::invalid_argument("Camera::project: points must have shape (..., 3), got " +
                                std::to_string(points.dim() ? points.size(-1) : 0) +
                                " in the last dimension");
  }
  return model_->project(params_tensor(points.options()), size(), points);
}

at::Tensor Camera::inside_image(const at::Tensor& pixels) const {
  const auto x = pixels.select(-1, 0);
  const auto y = pixels.select(-1, 1);
  return (x >= 0) & (x <= static_cast<double>(width_)) & (y >= 0) &
         (y <= static_cast<double>(height_));
}

at::Tensor Camera::pixel_centres(at::TensorOptions options) const {
  const auto xs = at::arange(width_, options).add_(0.5);
  const auto ys = at::arange(height_, options).add_(0.5);
  return at::stack({xs.view({1, width_}).expand({height_, width_}),
                    ys.view({height_, 1}).expand({height_, width_})},
                   -1);
}

Rays Camera::ray_map(at::TensorOptions options) const {
  return unproject(pixel_centres(options));
}

Camera Camera::resized(int64_t new_width, int64_t new_height) const {
  if (new_width <= 0 || new_height <= 0) {
    throw std::invalid_argument("cannot resize a camera to " + std::to_string(new_width) + "x" +
                                std::to_string(new_height));
  }
  const double sx = static_cast<double>(new_width) / width_;
  const double sy = static_cast<double>(new_height) / height_;
  return Camera(model_name_, new_width, new_height, model_->scaled_params(params_, sx, sy));
}

Camera Camera::cropped(int64_t x0, int64_t y0, int64_t width, int64_t height) const {
  if (width <= 0 || height <= 0) {
    throw std::invalid_argument("cannot crop a camera to " + std::to_string(width) + "x" +
                                std::to_string(height));
  }
  return Camera(model_name_, width, height,
                model_->cropped_params(params_, size(), static_cast<double>(x0),
                                       static_cast<double>(y0), {width, height}));
}

bool Camera::operator==(const Camera& other) const {
  return model_name_ == other.model_name_ && width_ == other.width_ && height_ == other.height_ &&
         params_ == other.params_;
}

Camera make_camera(const std::string& model, int64_t width, int64_t height,
                   std::vector<double> params) {
  return Camera(model, width, height, std::move(params));
}

Camera centred_pinhole(double horizontal_fov_deg, int64_t width, int64_t height) {
  if (!(horizontal_fov_deg > 0 && horizontal_fov_deg < 180)) {
    std::ostringstream text;
    text << "--fov: a pinhole camera's horizontal field of view must be in (0, 180) degrees, got "
         << horizontal_fov_deg;
    throw std::invalid_argument(text.str());
  }
  const double focal = 0.5 * width / std::tan(0.5 * horizontal_fov_deg * M_PI / 180.0);
  return Camera("PINHOLE", width, height, {focal, focal, 0.5 * width, 0.5 * height});
}

}  // namespace omnipoint::camera
