#include "omnipoint/camera/equidistant_fisheye.h"

#include <ATen/ATen.h>

#include <cmath>

#include "omnipoint/camera/lens_helpers.h"

namespace omnipoint::camera {
namespace {

constexpr double kPi = 3.14159265358979323846;
// Safeguarded Newton halves the bracket at worst, so this bounds the solve for any input.
constexpr int kMaxThetaIterations = 100;

// dθ_d/dθ = 1 + 3 k1 θ² + 5 k2 θ⁴ + ... for θ² = theta2.
at::Tensor radial_slope(const at::Tensor& theta2, const std::vector<at::Tensor>& k) {
  auto slope = at::ones_like(theta2);
  auto power = at::ones_like(theta2);
  for (std::size_t i = 0; i < k.size(); ++i) {
    power = power * theta2;
    slope = slope + static_cast<double>(2 * i + 3) * k[i] * power;
  }
  return slope;
}

double radial_slope(double theta, const std::vector<double>& k) {
  const double theta2 = theta * theta;
  double slope = 1.0;
  double power = 1.0;
  for (std::size_t i = 0; i < k.size(); ++i) {
    power *= theta2;
    slope += static_cast<double>(2 * i + 3) * k[i] * power;
  }
  return slope;
}

double distorted_theta(double theta, const std::vector<double>& k) {
  const double theta2 = theta * theta;
  double factor = 1.0;
  double power = 1.0;
  for (const double ki : k) {
    power *= theta2;
    factor += ki * power;
  }
  return theta * factor;
}

}  // namespace

at::Tensor radial_factor(const at::Tensor& theta2, const std::vector<at::Tensor>& k) {
  if (k.empty()) return at::ones_like(theta2);
  // Horner: 1 + t (k1 + t (k2 + ...)).
  auto acc = k.back() * at::ones_like(theta2);
  for (std::size_t i = k.size() - 1; i-- > 0;) acc = k[i] + theta2 * acc;
  return 1.0 + theta2 * acc;
}

double theta_limit(const std::vector<double>& k) {
  // The slope is 1 at θ = 0; scan (0, π] for its first non-positive value on a grid fine
  // enough for any physical lens, then bisect that cell to double precision.
  constexpr int kCells = 4096;
  double previous = 0.0;
  for (int j = 1; j <= kCells; ++j) {
    const double theta = kPi * j / kCells;
    if (radial_slope(theta, k) <= 0.0) {
      double rising = previous;
      double falling = theta;
      for (int i = 0; i < 200 && falling - rising > 0.0; ++i) {
        const double middle = 0.5 * (rising + falling);
        if (middle <= rising || middle >= falling) break;
        (radial_slope(middle, k) > 0.0 ? rising : falling) = middle;
      }
      return rising;
    }
    previous = theta;
  }
  return kPi;
}

at::Tensor solve_theta(const at::Tensor& theta_d, const std::vector<at::Tensor>& k,
                       double theta_max) {
  const auto target = theta_d.reshape(-1);
  auto theta = target.clamp(0.0, theta_max).clone();
  auto low = at::zeros_like(theta);
  auto high = at::full_like(theta, theta_max);
  auto active = at::arange(theta.numel(), theta.options().dtype(at::kLong));
  for (int iteration = 0; iteration < kMaxThetaIterations && active.numel() > 0; ++iteration) {
    const auto t = theta.index_select(0, active);
    const auto t2 = t * t;
    const auto residual = t * radial_factor(t2, k) - target.index_select(0, active);
    // θ_d rises on [0, θ_max], so the sign of the residual keeps the root bracketed.
    const auto above = residual > 0;
    const auto a = at::where(above, low.index_select(0, active), t);
    const auto b = at::where(above, t, high.index_select(0, active));
    const auto newton = t - residual / radial_slope(t2, k);
    const auto inside = (newton > a) & (newton < b);
    const auto next = at::where(residual == 0, t, at::where(inside, newton, 0.5 * (a + b)));
    theta.index_copy_(0, active, next);
    low.index_copy_(0, active, a);
    high.index_copy_(0, active, b);
    active = active.masked_select((next - t).abs() > kThetaTolerance);
  }
  return theta.view(theta_d.sizes());
}

std::vector<at::Tensor> EquidistantFisheyeModel::radial_coefficients(
    const at::Tensor& params) const {
  std::vector<at::Tensor> k;
  for (const int index : radial_indices()) k.push_back(params[index]);
  return k;
}

std::vector<double> EquidistantFisheyeModel::radial_coefficients(
    const std::vector<double>& params) const {
  std::vector<double> k;
  for (const int index : radial_indices()) k.push_back(params[index]);
  return k;
}

double EquidistantFisheyeModel::theta_max(const std::vector<double>& params) const {
  return theta_limit(radial_coefficients(params));
}

at::Tensor EquidistantFisheyeModel::distort(const at::Tensor& params,
                                            const at::Tensor& equidistant) const {
  const auto theta2 = squared_length(equidistant);
  return equidistant * radial_factor(theta2, radial_coefficients(params)).unsqueeze(-1);
}

void EquidistantFisheyeModel::check_params(const std::vector<double>& params, ImageSize) const {
  check_focal_positive(*this, params);
}

Pixels EquidistantFisheyeModel::project(const at::Tensor& params, ImageSize,
                                        const at::Tensor& points) const {
  const double limit = theta_max(host_values(params));
  const auto xy = points.narrow(-1, 0, 2);
  const auto distance = length(points);
  const auto theta = at::atan2(length(xy), points.select(-1, 2));
  // θ = π is the backward axis, whose direction in the image is undefined.
  auto valid = all_finite(points) & (distance > 0) & (theta < kPi) &
               (theta <= limit * (1.0 + fold_slack(points.scalar_type())));
  const auto safe_theta = at::where(valid, theta, at::zeros_like(theta));
  const auto safe_distance = at::where(valid, distance, at::ones_like(distance));
  // e = θ (x, y) / r = (x, y) / (d sin(θ) / θ): no division by r, smooth on the axis.
  auto equidistant = xy / (safe_distance * at::sinc(safe_theta / kPi)).unsqueeze(-1);
  equidistant = at::where(valid.unsqueeze(-1), equidistant, at::zeros_like(equidistant));
  if (!radial_only()) {
    const auto params64 = params.detach().to(at::kDouble);
    const Map2D g = [&](const at::Tensor& u) { return distort(params64, u); };
    valid = valid & locally_invertible(g, equidistant.detach().to(at::kDouble));
  }
  const auto pixels =
      denormalise_pixels(focal_principal(*this, params), distort(params, equidistant));
  return {at::where(valid.unsqueeze(-1), pixels, at::zeros_like(pixels)), valid};
}

Rays EquidistantFisheyeModel::unproject(const at::Tensor& params, ImageSize,
                                        const at::Tensor& pixels) const {
  const std::vector<double> k_host = radial_coefficients(host_values(params));
  const double limit = theta_limit(k_host);
  const double radius_max = distorted_theta(limit, k_host);

  const auto params64 = params.detach().to(at::kDouble);
  const auto k = radial_coefficients(params64);
  const auto [normalised, finite] = normalise_finite_pixels(*this, params64, pixels);

  // The radial inverse: exact for radial models, the starting point otherwise.
  const auto radius = length(normalised);
  const auto theta = solve_theta(radius.clamp_max(radius_max), k, limit);
  auto equidistant = normalised / radial_factor(theta * theta, k).unsqueeze(-1);
  auto valid = finite & (radius <= radius_max * (1.0 + fold_slack(pixels.scalar_type())));
  if (!radial_only()) {
    const Map2D g = [&](const at::Tensor& u) { return distort(params64, u); };
    // The other terms are small: a few fixed-point steps with the radial part's scale as the
    // Jacobian bring the start close, so that solve_2d only polishes. The start stays inside
    // the disc |e| < θ_max, where solve_2d searches.
    const double max_radius = limit * (1.0 + fold_slack(pixels.scalar_type()));
    for (int step = 0; step < 4; ++step) {
      const auto theta2 = squared_length(equidistant).unsqueeze(-1);
      equidistant = equidistant + (normalised - g(equidistant)) / radial_factor(theta2, k);
      const auto inside = (limit / length(equidistant).clamp_min(1e-300)).clamp_max(1.0);
      equidistant = equidistant * inside.unsqueeze(-1);
    }
    const auto solved = solve_2d(g, normalised, equidistant, max_radius);
    equidistant = solved.solution;
    valid = finite & solved.converged & locally_invertible(g, equidistant);
  }
  const auto angle = length(equidistant);
  valid = valid & (angle < kPi);
  const auto safe_angle = at::where(valid, angle, at::zeros_like(angle));
  // Length of e is θ: the ray is (e sin(θ) / θ, cos θ).
  const auto rays = at::cat(
      {equidistant * at::sinc(safe_angle / kPi).unsqueeze(-1), at::cos(safe_angle).unsqueeze(-1)},
      -1);
  return {at::where(valid.unsqueeze(-1), rays, at::zeros_like(rays)).to(pixels.scalar_type()),
          valid};
}

}  // namespace omnipoint::camera
