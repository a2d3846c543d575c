#include "omnipoint/camera/solve.h"

#include "omnipoint/camera/camera_model.h"

#include <ATen/ATen.h>

#include <cmath>
#include <limits>

namespace omnipoint::camera {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();

// Squared residual norm, +inf where g produced a non-finite value.
at::Tensor squared_norm(const at::Tensor& residual) {
  const auto cost = squared_length(residual);
  return at::where(at::isfinite(cost), cost, at::full_like(cost, kInfinity));
}

// Damping beyond which an element is considered stalled (about ten rejected steps in a row).
constexpr double kStalledDamping = 1e4;

}  // namespace

at::Tensor jacobian_2d(const Map2D& g, const at::Tensor& u, const at::Tensor& value) {
  // Step ~ sqrt(eps) relative to the point, the optimum for forward differences.
  const double relative = u.scalar_type() == at::kDouble ? 1.5e-8 : 3.5e-4;
  const auto h =
      at::maximum(u.select(-1, 0).abs(), u.select(-1, 1).abs()).clamp_min(1.0).unsqueeze(-1) *
      relative;  // (..., 1)
  const auto zero = at::zeros_like(h);
  const auto shifted = g(at::stack({u + at::cat({h, zero}, -1), u + at::cat({zero, h}, -1)}, 0));
  return at::stack({(shifted[0] - value) / h, (shifted[1] - value) / h}, -1);
}

Solve2DResult solve_2d(const Map2D& g, const at::Tensor& target, const at::Tensor& initial,
                       double max_radius, int max_iterations) {
  const auto batch_shape = target.sizes().vec();
  auto element_shape = batch_shape;
  element_shape.pop_back();
  const auto t = target.to(at::kDouble).reshape({-1, 2});
  auto u = initial.to(at::kDouble).reshape({-1, 2}).clone();
  const auto n = t.size(0);
  const auto tolerance = kSolveTolerance * (1 + length(t));
  auto value = g(u);
  auto cost = squared_norm(value - t);
  auto converged = cost.sqrt() <= tolerance;
  auto failed = length(u) >= max_radius;
  auto lambda = at::full({n}, 1e-6, t.options());

  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    const auto active = (~converged & ~failed).nonzero().squeeze(1);
    if (active.numel() == 0) break;
    const auto ua = u.index_select(0, active);
    const auto va = value.index_select(0, active);
    const auto ta = t.index_select(0, active);
    const auto ca = cost.index_select(0, active);
    const auto la = lambda.index_select(0, active);
    const auto ra = va - ta;

    // Damped normal equations (J^T J + lambda I) delta = -J^T r, written out for 2 x 2 (batched
    // matmul on tiny matrices is far slower than these element-wise products).
    const auto j = jacobian_2d(g, ua, va);
    const auto j00 = j.select(-1, 0).select(-1, 0), j01 = j.select(-1, 0).select(-1, 1);
    const auto j10 = j.select(-1, 1).select(-1, 0), j11 = j.select(-1, 1).select(-1, 1);
    const auto r0 = ra.select(-1, 0), r1 = ra.select(-1, 1);
    const auto a00 = j00 * j00 + j10 * j10 + la;
    const auto a11 = j01 * j01 + j11 * j11 + la;
    const auto a01 = j00 * j01 + j10 * j11;
    const auto b0 = j00 * r0 + j10 * r1;
    const auto b1 = j01 * r0 + j11 * r1;
    const auto det = a00 * a11 - a01 * a01;
    const auto delta = at::stack({(a01 * b1 - a11 * b0) / det, (a01 * b0 - a00 * b1) / det}, -1);

    const auto candidate = ua + delta;
    const auto candidate_value = g(candidate);
    const auto candidate_cost = squared_norm(candidate_value - ta);
    const auto accept = (candidate_cost < ca) & all_finite(delta);
    const auto accept2 = accept.unsqueeze(-1);
    const auto new_u = at::where(accept2, candidate, ua);
    const auto new_lambda = at::where(accept, (la * 0.1).clamp_min(1e-12), la * 10);

    u.index_copy_(0, active, new_u);
    value.index_copy_(0, active, at::where(accept2, candidate_value, va));
    cost.index_copy_(0, active, at::where(accept, candidate_cost, ca));
    lambda.index_copy_(0, active, new_lambda);
    failed.index_copy_(0, active, (new_lambda > kStalledDamping) | (length(new_u) >= max_radius));
    converged = cost.sqrt() <= tolerance;
  }
  return {u.reshape(batch_shape), (converged & (length(u) < max_radius)).reshape(element_shape)};
}

double monotonic_radius(const Map2D& g) {
  constexpr int kDirections = 16;
  const double min_radius = 1e-3, max_radius = 1e3, ratio = 1.01;
  const int count =
      static_cast<int>(std::ceil(std::log(max_radius / min_radius) / std::log(ratio))) + 1;
  const auto options = at::TensorOptions().dtype(at::kDouble);
  const auto radii = min_radius * at::pow(ratio, at::arange(count, options));  // (R)
  const auto angles = at::arange(kDirections, options) * (2 * M_PI / kDirections);
  const auto directions = at::stack({at::cos(angles), at::sin(angles)}, -1);  // (D, 2)
  const auto u = radii.view({-1, 1, 1}) * directions.unsqueeze(0);            // (R, D, 2)
  const auto j = jacobian_2d(g, u, g(u));
  const auto j00 = j.select(-1, 0).select(-1, 0);
  const auto j11 = j.select(-1, 1).select(-1, 1);
  const auto det = j00 * j11 - j.select(-1, 0).select(-1, 1) * j.select(-1, 1).select(-1, 0);
  const auto bad = (~((det > 0) & (j00 + j11 > 0))).any(1);  // (R); NaN counts as bad
  const auto first_bad = bad.nonzero();
  if (first_bad.numel() == 0) return kInfinity;
  const int64_t index = first_bad[0][0].item<int64_t>();
  return index == 0 ? 0.0 : radii[index - 1].item<double>();
}

}  // namespace omnipoint::camera
