#pragma once
// A robust batched solver for inverting 2-D lens distortions (the unprojection of models
// without a closed-form inverse), and the check that a distortion is invertible where it is
// evaluated (inside the monotonic range of its polynomial).
//
// `Map2D` maps points (..., 2) -> (..., 2) element by element: every row is independent of the
// others, so the batch may be reshaped, subset or stacked with a new leading dimension.
// Parameters are captured by the function (as 0-d or 1-d tensors that broadcast).
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
// Newton steps on the finite-difference Jacobian, damped (lambda * I added to J^T J) and
// rejected unless they reduce the residual; damping shrinks after a good step and grows after
// a bad one, so the solve neither diverges nor jumps between branches of the distortion.
// Computes in float64 whatever the input dtype, for at most `max_iterations` iterations, on
// the elements that have not converged yet. Elements whose residual stays above the
// tolerance (no preimage, e.g. beyond the distortion's range) have converged = false.
Solve2DResult solve_2d(const Map2D& g, const at::Tensor& target, const at::Tensor& initial,
                       int max_iterations = 60);

// Jacobian of g at u by central differences: (..., 2, 2), [..., i, j] = d g_i / d u_j.
at::Tensor jacobian_2d(const Map2D& g, const at::Tensor& u);

// Whether g is locally invertible and orientation-preserving (det J > 0 and trace J > 0, so
// no fold and no flip) at `samples` points evenly spaced along the segment from 0 to u, i.e.
// whether u lies in the monotonic range of the distortion that contains the origin. (...)
// bool. Pixels outside that range have no unique preimage: models mark them invalid.
at::Tensor invertible_from_origin(const Map2D& g, const at::Tensor& u, int samples = 8);

}  // namespace omnipoint::camera
