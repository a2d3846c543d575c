#include "omnipoint/camera/solve.h"

#include <ATen/ATen.h>

#include <limits>

namespace omnipoint::camera {
namespace {

// Squared residual norm, +inf where g produced a non-finite value.
at::Tensor squared_norm(const at::Tensor& residual) {
  const auto cost = residual.pow(2).sum(-1);
  return at::where(at::isfinite(cost), cost, at::full_like(cost, std::numeric_limits<double>::infinity()));
}

}  // namespace

at::Tensor jacobian_2d(const Map2D& g, const at::Tensor& u) {
  // Step ~ cbrt(eps) relative to the point, the optimum for central differences.
  const double eps = u.scalar_type() == at::kDouble ? 1e-16 : 1e-7;
  const double relative = std::cbrt(eps);
  const auto h = (u.abs().amax(-1, true).clamp_min(1.0) * relative);  // (..., 1)
  const auto hx = at::cat({h, at::zeros_like(h)}, -1);
  const auto hy = at::cat({at::zeros_like(h), h}, -1);
  const auto values = g(at::stack({u + hx, u - hx, u + hy, u - hy}, 0));
  const auto dx = (values[0] - values[1]) / (2 * h);  // d g / d u_x, (..., 2)
  const auto dy = (values[2] - values[3]) / (2 * h);
  return at::stack({dx, dy}, -1);
}

Solve2DResult solve_2d(const Map2D& g, const at::Tensor& target, const at::Tensor& initial,
                       int max_iterations) {
  const auto batch_shape = target.sizes().vec();
  const auto t = target.to(at::kDouble).reshape({-1, 2});
  auto u = initial.to(at::kDouble).reshape({-1, 2}).clone();
  const auto n = t.size(0);
  const auto tolerance = kSolveTolerance * (1 + t.norm(2, -1));
  auto residual = g(u) - t;
  auto cost = squared_norm(residual);
  auto converged = cost.sqrt() <= tolerance;
  auto lambda = at::full({n}, 1e-6, t.options());

  for (int iteration = 0; iteration < max_iterations; ++iteration) {
    const auto active = (~converged).nonzero().squeeze(1);
    if (active.numel() == 0) break;
    const auto ua = u.index_select(0, active);
    const auto ra = residual.index_select(0, active);
    const auto ca = cost.index_select(0, active);
    const auto la = lambda.index_select(0, active);

    // Damped normal equations (J^T J + lambda I) delta = -J^T r, solved in closed form.
    const auto j = jacobian_2d(g, ua);
    const auto jt = j.transpose(-1, -2);
    const auto a = at::matmul(jt, j);
    const auto b = at::matmul(jt, ra.unsqueeze(-1)).squeeze(-1);
    const auto a00 = a.select(-1, 0).select(-1, 0) + la;
    const auto a11 = a.select(-1, 1).select(-1, 1) + la;
    const auto a01 = a.select(-1, 0).select(-1, 1);
    const auto a10 = a.select(-1, 1).select(-1, 0);
    const auto det = a00 * a11 - a01 * a10;
    const auto b0 = b.select(-1, 0);
    const auto b1 = b.select(-1, 1);
    const auto delta = at::stack({-(a11 * b0 - a01 * b1) / det, -(a00 * b1 - a10 * b0) / det}, -1);

    const auto candidate = ua + delta;
    const auto candidate_residual = g(candidate) - t.index_select(0, active);
    const auto candidate_cost = squared_norm(candidate_residual);
    const auto accept = (candidate_cost < ca) & at::isfinite(delta).all(-1);

    const auto accept2 = accept.unsqueeze(-1);
    u.index_copy_(0, active, at::where(accept2, candidate, ua));
    residual.index_copy_(0, active, at::where(accept2, candidate_residual, ra));
    cost.index_copy_(0, active, at::where(accept, candidate_cost, ca));
    lambda.index_copy_(0, active, at::where(accept, (la * 0.1).clamp_min(1e-12), (la * 10).clamp_max(1e12)));
    converged = cost.sqrt() <= tolerance;
  }
  auto element_shape = batch_shape;
  element_shape.pop_back();
  return {u.reshape(batch_shape), converged.reshape(element_shape)};
}

at::Tensor invertible_from_origin(const Map2D& g, const at::Tensor& u, int samples) {
  const auto fractions =
      at::arange(1, samples + 1, u.options()).div_(samples).view({samples, 1}).expand({samples, u.numel() / 2});
  const auto flat = u.reshape({1, -1, 2});
  const auto along = flat * fractions.unsqueeze(-1);  // (samples, N, 2)
  const auto j = jacobian_2d(g, along.reshape({-1, 2})).reshape({samples, -1, 2, 2});
  const auto j00 = j.select(-1, 0).select(-1, 0);
  const auto j11 = j.select(-1, 1).select(-1, 1);
  const auto det = j00 * j11 - j.select(-1, 0).select(-1, 1) * j.select(-1, 1).select(-1, 0);
  const auto ok = ((det > 0) & (j00 + j11 > 0)).all(0);
  auto shape = u.sizes().vec();
  shape.pop_back();
  return ok.reshape(shape);
}

}  // namespace omnipoint::camera
