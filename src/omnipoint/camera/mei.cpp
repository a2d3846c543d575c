// MEI fx fy cx cy xi k1 k2 p1 p2: Mei's unified model with OpenCV-order radial-tangential
// distortion, as cv::omnidir (without its skew). The point moves to the unit sphere s, is
// projected from (0, 0, −ξ) onto the plane, m = (s_x, s_y) / (s_z + ξ), then distorted,
//   m_d = m (1 + k1 r² + k2 r⁴) + tangential(m; p1, p2),  pixel = f m_d + c.
// ξ >= 0. This is UCM with α = ξ / (1 + ξ) and f_ucm = f / (1 + ξ) when undistorted, so the
// domain is UCM's: z > −w d with w = ξ for ξ <= 1 and 1 / ξ beyond (a fold for ξ > 1). With
// distortion, points must also lie inside the radial polynomial's rising range
// (d/dr r (1 + k1 r² + k2 r⁴) > 0, solved in closed form) with the tangential terms locally
// invertible. Unprojection: closed form without distortion; otherwise solve_2d undistorts
// (tolerance kSolveTolerance, started from three fixed-point steps) and the closed-form lift
// to the sphere follows.
#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "omnipoint/camera/lens_helpers.h"
#include "omnipoint/camera/unified.h"

namespace omnipoint::camera {
namespace {

class MeiModel final : public CameraModel {
 public:
  std::string name() const override { return "MEI"; }
  std::vector<std::string> param_names() const override {
    return {"fx", "fy", "cx", "cy", "xi", "k1", "k2", "p1", "p2"};
  }

  void check_params(const std::vector<double>& params, ImageSize) const override {
    check_focal_positive(*this, params);
    const double xi = params[4];
    require_param(*this, "xi", xi, xi >= 0, ">= 0");
  }

  std::vector<double> initial_params(double fx, double fy, double cx, double cy,
                                     ImageSize size) const override {
    // ξ = 1 projects every direction but the backward axis; near the axis MEI is a pinhole
    // with focal f / (1 + ξ), hence the doubled focal lengths.
    auto params = CameraModel::initial_params(2 * fx, 2 * fy, cx, cy, size);
    params[4] = 1.0;  // xi
    return params;
  }

  Pixels project(const at::Tensor& params, ImageSize, const at::Tensor& points) const override {
    const auto host = host_values(params);
    const double xi_value = host[4];
    const auto xi = params[4];
    const auto xy = points.narrow(-1, 0, 2);
    const auto z = points.select(-1, 2);
    const auto d = length(points);
    const auto den = z + xi * d;
    const double w = unified_domain_weight(xi_value / (1.0 + xi_value));
    auto valid = all_finite(points) & (d > 0) & (den > 0) &
                 (z + w * d >= -fold_slack(points.scalar_type()) * d);
    auto plane = xy / at::where(valid, den, at::ones_like(den)).unsqueeze(-1);
    plane = at::where(valid.unsqueeze(-1), plane, at::zeros_like(plane));
    if (distorted(host)) {
      const auto params64 = params.detach().to(at::kDouble);
      const Map2D g = [&](const at::Tensor& u) { return distort(params64, u); };
      valid = valid & in_distortion_range(g, host, plane.detach().to(at::kDouble),
                                          fold_slack(points.scalar_type()));
    }
    const auto pixels = denormalise_pixels(focal_principal(*this, params), distort(params, plane));
    return {at::where(valid.unsqueeze(-1), pixels, at::zeros_like(pixels)), valid};
  }

  Rays unproject(const at::Tensor& params, ImageSize, const at::Tensor& pixels) const override {
    const auto host = host_values(params);
    const auto params64 = params.detach().to(at::kDouble);
    const auto xi = params64[4];
    const auto k1 = params64[5];
    const auto k2 = params64[6];
    const auto p1 = params64[7];
    const auto p2 = params64[8];
    auto [plane, valid] = normalise_finite_pixels(*this, params64, pixels);
    if (distorted(host)) {
      const Map2D g = [&](const at::Tensor& u) { return distort(params64, u); };
      // OpenCV's fixed-point undistortion u <- (m - tangential(u)) / radial(u), to start near.
      auto start = plane;
      for (int step = 0; step < 3; ++step) {
        const auto r2 = squared_length(start).unsqueeze(-1);
        start = (plane - tangential_distortion(start, p1, p2)) / (1.0 + k1 * r2 + k2 * r2 * r2);
      }
      // Preimages lie inside the distortion's rising range and, for ξ > 1, inside the image
      // of the sphere's fold, r² <= 1 / (ξ² − 1): the solve gives up on leaving that disc.
      const double xi_value = host[4];
      const double sphere_r2 = xi_value > 1 ? 1.0 / (xi_value * xi_value - 1.0)
                                            : std::numeric_limits<double>::infinity();
      const double max_radius = std::sqrt(std::min(radial_fold_r2(host), sphere_r2) *
                                          (1.0 + fold_slack(pixels.scalar_type())));
      const auto solved = solve_2d(g, plane, start, max_radius);
      plane = solved.solution;
      valid = valid & solved.converged &
              in_distortion_range(g, host, plane, fold_slack(pixels.scalar_type()));
    }
    const auto lifted =
        lift_to_shifted_sphere(at::cat({plane, at::ones_like(plane.narrow(-1, 0, 1))}, -1), xi,
                               fold_slack(pixels.scalar_type()));
    valid = valid & lifted.valid & all_finite(lifted.rays);
    return {at::where(valid.unsqueeze(-1), lifted.rays, at::zeros_like(lifted.rays))
                .to(pixels.scalar_type()),
            valid};
  }

 private:
  // Whether any of k1 k2 p1 p2 is non-zero (host values of the parameters).
  static bool distorted(const std::vector<double>& host) {
    const double k1 = host[5], k2 = host[6], p1 = host[7], p2 = host[8];
    return k1 != 0 || k2 != 0 || p1 != 0 || p2 != 0;
  }

  // The first r² > 0 where d/dr r (1 + k1 r² + k2 r⁴) = 1 + 3 k1 r² + 5 k2 r⁴ reaches 0
  // (host values of the parameters).
  static double radial_fold_r2(const std::vector<double>& host) {
    const double k1 = host[5], k2 = host[6];
    constexpr double kNone = std::numeric_limits<double>::infinity();
    if (k2 == 0) return k1 < 0 ? -1.0 / (3.0 * k1) : kNone;
    const double discriminant = 9.0 * k1 * k1 - 20.0 * k2;
    if (discriminant < 0) return kNone;
    double first = kNone;
    for (const double sign : {-1.0, 1.0}) {
      const double root = (-3.0 * k1 + sign * std::sqrt(discriminant)) / (10.0 * k2);
      if (root > 0 && root < first) first = root;
    }
    return first;
  }

  // Whether undistorted plane points u (..., 2) lie where the distortion is invertible.
  static at::Tensor in_distortion_range(const Map2D& g, const std::vector<double>& host,
                                        const at::Tensor& u, double slack) {
    const double fold = radial_fold_r2(host);
    return (squared_length(u) <= fold * (1.0 + slack)) & locally_invertible(g, u);
  }

  // Undistorted plane coordinates (..., 2) -> distorted ones.
  static at::Tensor distort(const at::Tensor& params, const at::Tensor& plane) {
    const auto k1 = params[5];
    const auto k2 = params[6];
    const auto p1 = params[7];
    const auto p2 = params[8];
    const auto r2 = squared_length(plane).unsqueeze(-1);
    return plane * (1.0 + k1 * r2 + k2 * r2 * r2) + tangential_distortion(plane, p1, p2);
  }
};

}  // namespace

const CameraModel& mei_model() {
  static const MeiModel model;
  return model;
}

}  // namespace omnipoint::camera
