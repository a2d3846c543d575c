// SIMPLE_PINHOLE (f cx cy) and PINHOLE (fx fy cx cy): the closed-form perspective models.
#include <ATen/ATen.h>

#include "omnipoint/camera/distorted_pinhole.h"

namespace omnipoint::camera {
namespace {

class PerspectiveModel : public CameraModel {
 public:
  void check_params(const std::vector<double>& params, ImageSize) const override {
    check_focal_positive(*this, params);
  }
  Pixels project(const at::Tensor& params, ImageSize, const at::Tensor& points) const override {
    const auto plane = project_to_plane(points);
    const auto pixels = denormalise_pixels(focal_principal(*this, params), plane.normalised);
    return {at::where(plane.valid.unsqueeze(-1), pixels, at::zeros_like(pixels)), plane.valid};
  }
  Rays unproject(const at::Tensor& params, ImageSize, const at::Tensor& pixels) const override {
    const auto rays = rays_from_plane(normalise_pixels(focal_principal(*this, params), pixels));
    return {rays, at::ones_like(pixels.select(-1, 0), pixels.options().dtype(at::kBool))};
  }
};

class SimplePinholeModel final : public PerspectiveModel {
 public:
  std::string name() const override { return "SIMPLE_PINHOLE"; }
  std::vector<std::string> param_names() const override { return {"f", "cx", "cy"}; }
};

class PinholeModel final : public PerspectiveModel {
 public:
  std::string name() const override { return "PINHOLE"; }
  std::vector<std::string> param_names() const override { return {"fx", "fy", "cx", "cy"}; }
};

}  // namespace

const CameraModel& simple_pinhole_model() {
  static const SimplePinholeModel model;
  return model;
}

const CameraModel& pinhole_model() {
  static const PinholeModel model;
  return model;
}

}  // namespace omnipoint::camera
