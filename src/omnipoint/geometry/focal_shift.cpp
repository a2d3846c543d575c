#include "omnipoint/geometry/focal_shift.h"

#include <ATen/ATen.h>
#include <torch/nn/functional/upsampling.h>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "omnipoint/geometry/view_plane_uv.h"

namespace omnipoint::geometry {

namespace {

namespace F = torch::nn::functional;

// The samples of a batch of images, padded: invalid samples have xy = 0, z = 1, uv = 0 and
// therefore contribute nothing to any sum or residual.
struct Samples {
  at::Tensor xy;  // (B,S,2)
  at::Tensor z;   // (B,S)
  at::Tensor uv;  // (B,S,2)
};

// Projections p(s) = xy / (z + s) and the optimal focal f(s) = Σ p·uv / Σ p·p.
std::pair<at::Tensor, at::Tensor> project(const Samples& samples, const at::Tensor& shift) {
  const at::Tensor projected = samples.xy / (samples.z + shift.unsqueeze(1)).unsqueeze(-1);
  const at::Tensor focal = (projected * samples.uv).sum({1, 2}) / projected.square().sum({1, 2});
  return {projected, focal};
}

at::Tensor residuals(const Samples& samples, const at::Tensor& shift) {  // (B,S,2)
  const auto [projected, focal] = project(samples, shift);
  return focal.view({-1, 1, 1}) * projected - samples.uv;
}

at::Tensor sum_of_squares(const at::Tensor& residual) {
  return residual.square().sum({1, 2});
}

// Gauss-Newton on the shift with MINPACK's forward-difference derivative (step
// sqrt(eps)·|s|, or sqrt(eps) at s = 0) and its ftol test; a step that does not reduce the
// cost is halved on the next iteration instead of taken.
at::Tensor solve_shift(const Samples& samples, at::Tensor done, const FocalShiftOptions& options) {
  const double sqrt_eps = std::sqrt(std::numeric_limits<double>::epsilon());
  at::Tensor shift = at::zeros({samples.z.size(0)}, samples.z.options());
  at::Tensor damping = at::ones_like(shift);
  at::Tensor residual = residuals(samples, shift);
  at::Tensor cost = sum_of_squares(residual);
  for (int64_t iteration = 0; iteration < options.max_iterations; ++iteration) {
    if (done.all().item<bool>()) break;
    at::Tensor step_size = sqrt_eps * shift.abs();
    step_size = at::where(step_size == 0, at::full_like(step_size, sqrt_eps), step_size);
    const at::Tensor jacobian =
        (residuals(samples, shift + step_size) - residual) / step_size.view({-1, 1, 1});
    const at::Tensor gradient = (jacobian * residual).sum({1, 2});
    const at::Tensor curvature = jacobian.square().sum({1, 2});
    done = done | ~(curvature > 0) | (damping < 1e-12);
    const at::Tensor step = at::where(done, at::zeros_like(shift), -gradient / curvature * damping);
    const at::Tensor trial_shift = shift + step;
    const at::Tensor trial_residual = residuals(samples, trial_shift);
    const at::Tensor trial_cost = sum_of_squares(trial_residual);
    // Relative actual and predicted (linear model) decrease of the sum of squares.
    const at::Tensor actual = 1 - trial_cost / cost;
    const at::Tensor predicted =
        (2 * damping - damping.square()) * gradient.square() / (curvature * cost);
    const at::Tensor accepted = ~done & (trial_cost < cost);
    const at::Tensor converged = (actual.abs() <= options.ftol) & (predicted <= options.ftol);
    shift = at::where(accepted, trial_shift, shift);
    residual = at::where(accepted.view({-1, 1, 1}), trial_residual, residual);
    cost = at::where(accepted, trial_cost, cost);
    damping = at::where(accepted, at::ones_like(damping), damping * 0.5);
    done = done | converged | (cost == 0);
  }
  return shift;
}

}  // namespace

FocalShift recover_focal_shift(const at::Tensor& points, const at::Tensor& mask,
                               const FocalShiftOptions& options) {
  if (points.dim() != 4 || points.size(3) != 3)
    throw std::invalid_argument("recover_focal_shift: points must be (B,H,W,3), got " +
                                c10::str(points.sizes()));
  const int64_t batch = points.size(0), height = points.size(1), width = points.size(2);
  if (mask.defined() &&
      (mask.dim() != 3 || mask.size(0) != batch || mask.size(1) != height || mask.size(2) != width))
    throw std::invalid_argument("recover_focal_shift: mask must be (B,H,W) like the points, got " +
                                c10::str(mask.sizes()));
  const int64_t side = options.subsample_size;
  const auto nearest =
      F::InterpolateFuncOptions().size(std::vector<int64_t>{side, side}).mode(torch::kNearest);

  // Nearest-neighbour subsample of the points, the view-plane uv and the mask (in the
  // points' dtype, as MoGe), then float64 for the solve.
  const at::Tensor uv = normalized_view_plane_uv(width, height, static_cast<double>(width) / height,
                                                 points.options());
  const at::Tensor points_lr = F::interpolate(points.permute({0, 3, 1, 2}), nearest)
                                   .permute({0, 2, 3, 1})
                                   .reshape({batch, -1, 3});
  const at::Tensor uv_lr = F::interpolate(uv.permute({2, 0, 1}).unsqueeze(0), nearest)
                               .permute({0, 2, 3, 1})
                               .reshape({1, -1, 2});
  at::Tensor valid = at::ones({batch, side * side}, points.options().dtype(at::kBool));
  if (mask.defined())
    valid = F::interpolate(mask.to(at::kFloat).unsqueeze(1), nearest).reshape({batch, -1}) > 0;

  const auto f64 = points.options().dtype(at::kDouble);
  Samples samples;
  samples.xy =
      at::where(valid.unsqueeze(-1), points_lr.narrow(2, 0, 2).to(at::kDouble), at::zeros({}, f64));
  samples.z = at::where(valid, points_lr.select(2, 2).to(at::kDouble), at::ones({}, f64));
  samples.uv = at::where(valid.unsqueeze(-1), uv_lr.to(at::kDouble), at::zeros({}, f64));

  const at::Tensor too_few = valid.sum(1) < 2;
  const at::Tensor shift = solve_shift(samples, too_few, options).to(points.scalar_type());
  const at::Tensor focal = project(samples, shift.to(at::kDouble)).second.to(points.scalar_type());
  return {at::where(too_few, at::ones_like(focal), focal),
          at::where(too_few, at::zeros_like(shift), shift)};
}

at::Tensor intrinsics_from_focal(const at::Tensor& focal, double aspect_ratio) {
  if (!(aspect_ratio > 0))
    throw std::invalid_argument("intrinsics_from_focal: aspect ratio must be > 0");
  const double diagonal = std::sqrt(1 + aspect_ratio * aspect_ratio);
  const at::Tensor fx = focal / 2 * diagonal / aspect_ratio;
  const at::Tensor fy = focal / 2 * diagonal;
  const at::Tensor zero = at::zeros_like(focal), half = at::full_like(focal, 0.5),
                   one = at::ones_like(focal);
  return at::stack({fx, zero, half, zero, fy, half, zero, zero, one}, -1).view({-1, 3, 3});
}

at::Tensor depth_to_points(const at::Tensor& depth, const at::Tensor& intrinsics) {
  if (depth.dim() != 3 || intrinsics.dim() != 3 || intrinsics.size(0) != depth.size(0) ||
      intrinsics.size(1) != 3 || intrinsics.size(2) != 3)
    throw std::invalid_argument("depth_to_points: need depth (B,H,W) and intrinsics (B,3,3), got " +
                                c10::str(depth.sizes()) + " and " + c10::str(intrinsics.sizes()));
  const int64_t height = depth.size(1), width = depth.size(2);
  const auto options = depth.options();
  const at::Tensor u = (at::arange(width, options) + 0.5) / width;
  const at::Tensor v = (at::arange(height, options) + 0.5) / height;
  const auto entry = [&](int64_t row, int64_t col) {
    return intrinsics.select(1, row).select(1, col).view({-1, 1, 1});
  };
  const at::Tensor x = (u.view({1, 1, width}) - entry(0, 2)) / entry(0, 0) * depth;
  const at::Tensor y = (v.view({1, height, 1}) - entry(1, 2)) / entry(1, 1) * depth;
  return at::stack({x, y, depth}, -1);
}

}  // namespace omnipoint::geometry
