// Equidistant fisheye models with tangential and thin-prism terms (COLMAP's names and
// parameter orders); e = θ (x, y) / r are the equidistant coordinates, r_e² = |e|² = θ².
//
// THIN_PRISM_FISHEYE  fx fy cx cy k1 k2 p1 p2 k3 k4 sx1 sy1 (Weng et al. 1992):
//   d = e (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸) + tangential(e; p1, p2) + (sx1, sy1) θ²
// RAD_TAN_THIN_PRISM_FISHEYE  fx fy cx cy k0 k1 k2 k3 k4 k5 p0 p1 s0 s1 s2 s3 (Meta's
// Fisheye624): with g = e (1 + k0 θ² + ... + k5 θ¹²) and ρ² = |g|²,
//   d = g + tangential(g; p1, p0) + (s0 ρ² + s1 ρ⁴, s2 ρ² + s3 ρ⁴)
// where tangential(x; a, b) = (2 a x y + b (ρ² + 2 x²), a (ρ² + 2 y²) + 2 b x y) is OpenCV's.
// pixel = f d + c. Unprojection inverts d with solve_2d (see equidistant_fisheye.h).
#include <ATen/ATen.h>

#include "omnipoint/camera/equidistant_fisheye.h"
#include "omnipoint/camera/lens_helpers.h"

namespace omnipoint::camera {
namespace {

class ThinPrismFisheyeModel final : public EquidistantFisheyeModel {
 public:
  std::string name() const override { return "THIN_PRISM_FISHEYE"; }
  std::vector<std::string> param_names() const override {
    return {"fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3", "k4", "sx1", "sy1"};
  }
  std::vector<int> radial_indices() const override { return {4, 5, 8, 9}; }  // k1 k2 k3 k4
  bool radial_only() const override { return false; }

  at::Tensor distort(const at::Tensor& params, const at::Tensor& e) const override {
    const auto p1 = params[6];
    const auto p2 = params[7];
    const auto sx1 = params[10];
    const auto sy1 = params[11];
    const auto theta2 = squared_length(e).unsqueeze(-1);
    const auto prism = at::stack({sx1, sy1}) * theta2;
    return EquidistantFisheyeModel::distort(params, e) + tangential_distortion(e, p1, p2) + prism;
  }
};

class RadTanThinPrismFisheyeModel final : public EquidistantFisheyeModel {
 public:
  std::string name() const override { return "RAD_TAN_THIN_PRISM_FISHEYE"; }
  std::vector<std::string> param_names() const override {
    return {"fx", "fy", "cx", "cy", "k0", "k1", "k2", "k3",
            "k4", "k5", "p0", "p1", "s0", "s1", "s2", "s3"};
  }
  std::vector<int> radial_indices() const override {
    return {4, 5, 6, 7, 8, 9};  // k0 k1 k2 k3 k4 k5
  }
  bool radial_only() const override { return false; }

  at::Tensor distort(const at::Tensor& params, const at::Tensor& e) const override {
    const auto p0 = params[10];
    const auto p1 = params[11];
    const auto s0 = params[12];
    const auto s1 = params[13];
    const auto s2 = params[14];
    const auto s3 = params[15];
    const auto g = EquidistantFisheyeModel::distort(params, e);
    const auto rho2 = squared_length(g).unsqueeze(-1);
    const auto prism = at::stack({s0, s2}) * rho2 + at::stack({s1, s3}) * rho2 * rho2;
    return g + tangential_distortion(g, p1, p0) + prism;
  }
};

}  // namespace

const CameraModel& thin_prism_fisheye_model() {
  static const ThinPrismFisheyeModel model;
  return model;
}

const CameraModel& rad_tan_thin_prism_fisheye_model() {
  static const RadTanThinPrismFisheyeModel model;
  return model;
}

}  // namespace omnipoint::camera
