// SIMPLE_RADIAL (f cx cy k) and RADIAL (f cx cy k1 k2): COLMAP's radial distortion of
// normalised coordinates, u_d = u * (1 + k1 r^2 + k2 r^4), inverted by solve_2d.
#include <ATen/ATen.h>

#include "omnipoint/camera/distorted_pinhole.h"

namespace omnipoint::camera {
namespace {

class SimpleRadialModel final : public DistortedPinholeModel {
 public:
  std::string name() const override { return "SIMPLE_RADIAL"; }
  std::vector<std::string> param_names() const override { return {"f", "cx", "cy", "k"}; }
  at::Tensor distort(const at::Tensor& params, const at::Tensor& u) const override {
    const auto k = params[3];
    const auto r2 = squared_length(u).unsqueeze(-1);
    return u * (1 + k * r2);
  }
};

class RadialModel final : public DistortedPinholeModel {
 public:
  std::string name() const override { return "RADIAL"; }
  std::vector<std::string> param_names() const override { return {"f", "cx", "cy", "k1", "k2"}; }
  at::Tensor distort(const at::Tensor& params, const at::Tensor& u) const override {
    const auto k1 = params[3];
    const auto k2 = params[4];
    const auto r2 = squared_length(u).unsqueeze(-1);
    return u * (1 + r2 * (k1 + k2 * r2));
  }
};

}  // namespace

const CameraModel& simple_radial_model() {
  static const SimpleRadialModel model;
  return model;
}

const CameraModel& radial_model() {
  static const RadialModel model;
  return model;
}

}  // namespace omnipoint::camera
