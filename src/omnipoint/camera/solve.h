#pragma once
// A robust batched solver for inverting 2-D lens distortions (the unprojection of models
// without a closed-form inverse), and the domain where such a distortion is invertible (the
// monotonic range of its polynomial around the axis).
//
// `Map2D` maps points (..., 2) -> (..., 2) element by element: every row is independent of the
// others, so the batch may be reshaped, subset or stacked with a new leading dimension.
// Parameters are captured by the function (as 0-d tensors that broadcast).
#include <ATen/core/Tensor.h>

#include <functional>

namespace omnipoint::camera {

using Map2D = std::function<at::Tensor(const at::Tensor&)>;

struct Solve2DResult {
  at::Tensor solution;   // (..., 2) float64; meaningless where not converged
  at::Tensor converged;  // (...) bool
};

// Residual tolerance of solve_2d: |g(u) - target| <= kSolveTolerance * (1 + |target|).
// In normalised coordinates this is ~1e-9 px for a 1000 px focal length.
constexpr double kSolveTolerance = 1e-12;

// Solves g(u) = target for u by Levenberg-Marquardt, independently for every element:
// Gauss-Newton steps on a finite-difference Jacobian, damped (lambda * I added to J^T J) and
// rejected unless they reduce the residual; damping shrinks after a good step and grows after
// a bad one, so the solve neither diverges nor jumps between branches of the distortion.
// Computes in float64 whatever the input dtype, on the elements still unconverged, for at
// most `max_iterations` iterations. An element fails (converged = false) when its residual
// stays above the tolerance: it stalls (no preimage, e.g. beyond the distortion's range) or
// leaves the disc |u| < max_radius (see monotonic_radius).
Solve2DResult solve_2d(const Map2D& g, const at::Tensor& target, const at::Tensor& initial,
                       double max_radius, int max_iterations = 50);

// Jacobian of g at u by forward differences: (..., 2, 2), [..., i, j] = d g_i / d u_j.
// `value` is g(u), already known to the caller.
at::Tensor jacobian_2d(const Map2D& g, const at::Tensor& u, const at::Tensor& value);

// The radius of the largest disc around the origin in which g is locally invertible and
// orientation-preserving (det J > 0 and trace J > 0: no fold, no flip), i.e. the monotonic
// range of the distortion. Found on a polar grid (16 directions, radii log-spaced from 1e-3
// to 1e3, 1% apart) and rounded down to a grid radius; +inf when g is monotonic on the
// whole grid. `g` must accept CPU float64 tensors. Inside this disc the preimage solve_2d
// finds is unique; pixels whose preimage lies outside are invalid.
double monotonic_radius(const Map2D& g);

}  // namespace omnipoint::camera
