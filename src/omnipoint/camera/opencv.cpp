// OPENCV (fx fy cx cy k1 k2 p1 p2) and FULL_OPENCV (fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6):
// OpenCV's radial (polynomial / rational) and tangential distortion of normalised
// coordinates, in COLMAP's parameter order, inverted by solve_2d.
#include <ATen/ATen.h>

#include "omnipoint/camera/distorted_pinhole.h"

namespace omnipoint::camera {
namespace {

// u * radial + the tangential terms (p1, p2).
at::Tensor radial_tangential(const at::Tensor& u, const at::Tensor& radial, const at::Tensor& p1,
                             const at::Tensor& p2) {
  const auto x = u.select(-1, 0);
  const auto y = u.select(-1, 1);
  const auto xy = x * y;
  const auto r2 = x * x + y * y;
  const auto r = radial.squeeze(-1);
  return at::stack(
      {x * r + 2 * p1 * xy + p2 * (r2 + 2 * x * x), y * r + 2 * p2 * xy + p1 * (r2 + 2 * y * y)},
      -1);
}

class OpenCVModel final : public DistortedPinholeModel {
 public:
  std::string name() const override { return "OPENCV"; }
  std::vector<std::string> param_names() const override {
    return {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"};
  }
  at::Tensor distort(const at::Tensor& params, const at::Tensor& u) const override {
    const auto k1 = params[4];
    const auto k2 = params[5];
    const auto p1 = params[6];
    const auto p2 = params[7];
    const auto r2 = squared_length(u).unsqueeze(-1);
    const auto radial = 1 + r2 * (k1 + k2 * r2);
    return radial_tangential(u, radial, p1, p2);
  }
};

class FullOpenCVModel final : public DistortedPinholeModel {
 public:
  std::string name() const override { return "FULL_OPENCV"; }
  std::vector<std::string> param_names() const override {
    return {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6"};
  }
  at::Tensor distort(const at::Tensor& params, const at::Tensor& u) const override {
    const auto k1 = params[4];
    const auto k2 = params[5];
    const auto p1 = params[6];
    const auto p2 = params[7];
    const auto k3 = params[8];
    const auto k4 = params[9];
    const auto k5 = params[10];
    const auto k6 = params[11];
    const auto r2 = squared_length(u).unsqueeze(-1);
    const auto numerator = 1 + r2 * (k1 + r2 * (k2 + r2 * k3));
    const auto denominator = 1 + r2 * (k4 + r2 * (k5 + r2 * k6));
    return radial_tangential(u, numerator / denominator, p1, p2);
  }
};

}  // namespace

const CameraModel& opencv_model() {
  static const OpenCVModel model;
  return model;
}

const CameraModel& full_opencv_model() {
  static const FullOpenCVModel model;
  return model;
}

}  // namespace omnipoint::camera
