#include "omnipoint/camera/camera_model.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <sstream>
#include <stdexcept>

namespace omnipoint::camera {
namespace {

// Index of the parameter called `name`, or -1.
int index_of(const std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  return it == names.end() ? -1 : static_cast<int>(it - names.begin());
}

}  // namespace

bool CameraModel::accepts_param_count(std::size_t count) const {
  return count == param_names().size();
}

std::string CameraModel::expected_params() const {
  const auto names = param_names();
  std::ostringstream text;
  text << names.size() << " parameters (";
  for (std::size_t i = 0; i < names.size(); ++i) text << (i ? " " : "") << names[i];
  text << ")";
  return text.str();
}

void CameraModel::check_params(const std::vector<double>&, ImageSize) const {}

std::vector<double> CameraModel::scaled_params(const std::vector<double>& params, double sx,
                                               double sy) const {
  const auto names = param_names();
  std::vector<double> scaled = params;
  for (std::size_t i = 0; i < names.size() && i < scaled.size(); ++i) {
    if (names[i] == "f") scaled[i] *= 0.5 * (sx + sy);
    if (names[i] == "fx" || names[i] == "cx") scaled[i] *= sx;
    if (names[i] == "fy" || names[i] == "cy") scaled[i] *= sy;
  }
  return scaled;
}

std::vector<double> CameraModel::cropped_params(const std::vector<double>& params, ImageSize,
                                                double x0, double y0, ImageSize) const {
  const auto names = param_names();
  std::vector<double> cropped = params;
  const int cx = index_of(names, "cx");
  const int cy = index_of(names, "cy");
  if (cx >= 0) cropped[cx] -= x0;
  if (cy >= 0) cropped[cy] -= y0;
  return cropped;
}

std::vector<double> CameraModel::initial_params(double fx, double fy, double cx, double cy,
                                                ImageSize) const {
  const auto names = param_names();
  std::vector<double> params(names.size(), 0.0);
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == "f") params[i] = 0.5 * (fx + fy);
    if (names[i] == "fx") params[i] = fx;
    if (names[i] == "fy") params[i] = fy;
    if (names[i] == "cx") params[i] = cx;
    if (names[i] == "cy") params[i] = cy;
  }
  return params;
}

FocalPrincipal focal_principal(const CameraModel& model, const at::Tensor& params) {
  const auto names = model.param_names();
  const int f = index_of(names, "f");
  const int fx = f >= 0 ? f : index_of(names, "fx");
  const int fy = f >= 0 ? f : index_of(names, "fy");
  const int cx = index_of(names, "cx");
  const int cy = index_of(names, "cy");
  if (fx < 0 || fy < 0 || cx < 0 || cy < 0) {
    throw std::logic_error(model.name() + " has no focal length / principal point parameters");
  }
  return {params[fx], params[fy], params[cx], params[cy]};
}

at::Tensor normalise_pixels(const FocalPrincipal& k, const at::Tensor& pixels) {
  return at::stack({(pixels.select(-1, 0) - k.cx) / k.fx, (pixels.select(-1, 1) - k.cy) / k.fy},
                   -1);
}

at::Tensor denormalise_pixels(const FocalPrincipal& k, const at::Tensor& normalised) {
  return at::stack({normalised.select(-1, 0) * k.fx + k.cx, normalised.select(-1, 1) * k.fy + k.cy},
                   -1);
}

at::Tensor rays_from_plane(const at::Tensor& normalised) {
  const auto ones = at::ones_like(normalised.select(-1, 0)).unsqueeze(-1);
  const auto homogeneous = at::cat({normalised, ones}, -1);
  return homogeneous / length(homogeneous).unsqueeze(-1);
}

at::Tensor squared_length(const at::Tensor& v) {
  auto sum = v.select(-1, 0) * v.select(-1, 0);
  for (int64_t i = 1; i < v.size(-1); ++i) sum = sum + v.select(-1, i) * v.select(-1, i);
  return sum;
}

at::Tensor length(const at::Tensor& v) {
  return at::sqrt(squared_length(v));
}

at::Tensor all_finite(const at::Tensor& v) {
  auto finite = at::isfinite(v.select(-1, 0));
  for (int64_t i = 1; i < v.size(-1); ++i) finite = finite & at::isfinite(v.select(-1, i));
  return finite;
}

void require_param(const CameraModel& model, const std::string& name, double value, bool ok,
                   const std::string& expected) {
  if (ok) return;
  std::ostringstream text;
  text.precision(17);
  text << model.name() << ": " << name << " must be " << expected << ", got " << value;
  throw std::invalid_argument(text.str());
}

void check_focal_positive(const CameraModel& model, const std::vector<double>& params) {
  const auto names = model.param_names();
  for (std::size_t i = 0; i < names.size() && i < params.size(); ++i) {
    if (names[i] == "f" || names[i] == "fx" || names[i] == "fy")
      require_param(model, "focal length " + names[i], params[i], params[i] > 0, "> 0");
  }
}

}  // namespace omnipoint::camera
