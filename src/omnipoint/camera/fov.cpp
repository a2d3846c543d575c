// FOV (fx fy cx cy omega): the field-of-view model of Devernay and Faugeras as in COLMAP,
// r_d = atan(2 r tan(omega / 2)) / omega on normalised coordinates, with the closed-form
// inverse r = tan(r_d omega) / (2 tan(omega / 2)). Defined for z > 0; pixels with
// r_d omega >= pi / 2 (beyond 90 degrees off-axis) are invalid. omega = 0 is the pinhole.
#include <ATen/ATen.h>

#include <cmath>

#include "omnipoint/camera/distorted_pinhole.h"

namespace omnipoint::camera {
namespace {

// Radii below this use the limit r -> 0 of the radial factor.
constexpr double kSmallRadius = 1e-12;

class FovModel final : public CameraModel {
 public:
  std::string name() const override { return "FOV"; }
  std::vector<std::string> param_names() const override {
    return {"fx", "fy", "cx", "cy", "omega"};
  }

  void check_params(const std::vector<double>& params, ImageSize) const override {
    check_focal_positive(*this, params);
    const double omega = params[4];
    require_param(*this, "omega", omega, omega >= 0 && omega < M_PI, "in [0, pi) radians");
  }

  Pixels project(const at::Tensor& params, ImageSize, const at::Tensor& points) const override {
    const auto plane = project_to_plane(points);
    const double omega = params[4].item<double>();
    auto distorted = plane.normalised;
    if (omega > 0) {
      const double two_tan = 2 * std::tan(omega / 2);
      const auto r = length(plane.normalised).unsqueeze(-1);
      const auto small = r < kSmallRadius;
      const auto safe_r = at::where(small, at::ones_like(r), r);
      const auto factor = at::where(small, at::full_like(r, two_tan / omega),
                                    at::atan(two_tan * safe_r) / (omega * safe_r));
      distorted = plane.normalised * factor;
    }
    const auto pixels = denormalise_pixels(focal_principal(*this, params), distorted);
    return {at::where(plane.valid.unsqueeze(-1), pixels, at::zeros_like(pixels)), plane.valid};
  }

  Rays unproject(const at::Tensor& params, ImageSize, const at::Tensor& pixels) const override {
    const auto distorted = normalise_pixels(focal_principal(*this, params), pixels);
    const double omega = params[4].item<double>();
    if (omega == 0) {
      return {rays_from_plane(distorted),
              at::ones_like(pixels.select(-1, 0), pixels.options().dtype(at::kBool))};
    }
    const double two_tan = 2 * std::tan(omega / 2);
    const auto rd = length(distorted).unsqueeze(-1);
    const auto valid = (rd * omega < M_PI / 2).squeeze(-1);
    const auto small = rd < kSmallRadius;
    const auto safe_rd = at::where(small | ~valid.unsqueeze(-1), at::full_like(rd, 0.5), rd);
    const auto factor = at::where(small, at::full_like(rd, omega / two_tan),
                                  at::tan(safe_rd * omega) / (two_tan * safe_rd));
    const auto rays = rays_from_plane(distorted * factor);
    return {at::where(valid.unsqueeze(-1), rays, at::zeros_like(rays)), valid};
  }
};

}  // namespace

const CameraModel& fov_model() {
  static const FovModel model;
  return model;
}

}  // namespace omnipoint::camera
