#pragma once
// Robust exact L1 alignment ("ROE", MoGe): global optima of weighted-L1 fits between a
// source (prediction) and a target (ground truth).
//
// Conventions, shared by every function here:
// - Batched: samples lie along the last dimension n (points: the last two, (n, 3)); all
//   leading dimensions are batch dimensions. Results have the batch shape.
// - `weight` (same shape as the samples; points: without the trailing 3) is >= 0.
//   `mask` (bool, same shape as `weight`) is optional: masked-out samples are ignored,
//   whatever their values (NaN or inf included). Pass an undefined tensor for "all valid".
// - dtype and device come from the inputs (float32 or float64, CPU or CUDA).
// - A batch item without any usable sample (no positive weight·|x|) gets NaN results.
// - Exact means the global optimum of the stated objective, in real arithmetic; ties are
//   resolved like MoGe: the weighted median is the first sorted element whose cumulative
//   weight reaches half of the total.
#include <ATen/core/Tensor.h>

namespace omnipoint::geometry {

// min_a Σ w_i |a·x_i − y_i|: the weighted median of y/x with weights w·|x|.
struct ScaleFit {
  at::Tensor scale;  // (batch)
  at::Tensor loss;   // (batch) Σ w|a x − y| at the optimum
  at::Tensor index;  // (batch) int64: a = y[index] / x[index]
};
ScaleFit fit_scale_l1(const at::Tensor& x, const at::Tensor& y, const at::Tensor& weight,
                      const at::Tensor& mask = {});

// The metric post-alignment to sparse depth (paper): per item the factor a minimising
// Σ |a·x_i − y_i| / y_i over the samples with y finite and > 0, x > 0 and `mask` — fit_scale_l1
// with weights 1/y. x = predicted metric distances, y = sparse metric distances, (..., n);
// items without such samples get 1.
at::Tensor fit_scale_to_sparse_depth(const at::Tensor& x, const at::Tensor& y,
                                     const at::Tensor& mask = {});

// The truncated variant used by MoGe's training losses: min_a Σ min(trunc, w_i|a·x_i − y_i|)
// (trunc > 0). The objective is not convex, but its minimum lies at one of the ratios
// y_i/x_i; all n candidates are scored at once with prefix sums, O(n log n).
ScaleFit fit_scale_l1_truncated(const at::Tensor& x, const at::Tensor& y, const at::Tensor& weight,
                                double trunc, const at::Tensor& mask = {});

// min_{s,t} Σ w_i |s·x_i + t − y_i| (depth: affine-invariant alignment).
struct AffineFit {
  at::Tensor scale;  // (batch)
  at::Tensor shift;  // (batch) for depth, (batch, 3) for points
  at::Tensor loss;   // (batch) objective at (scale, shift)
};
// Fast exact solver (computed in float64): a descent over weighted-median pivots, a few
// sorts per iteration and a handful of iterations (alignment.cpp argues exactness; slopes
// closer than a relative 1e-9 count as tied). About 240× faster than MoGe's method at n = 4,096.
AffineFit fit_affine_l1(const at::Tensor& x, const at::Tensor& y, const at::Tensor& weight,
                        const at::Tensor& mask = {});
// MoGe's reference method: every sample as an anchor, a scale fit through it, the best
// anchor wins. O(n² log n); kept as the reference the fast solver is tested against.
AffineFit fit_affine_l1_brute_force(const at::Tensor& x, const at::Tensor& y,
                                    const at::Tensor& weight, const at::Tensor& mask = {});

// Points (..., n, 3), weight (..., n): one scale for all coordinates pooled,
// min_s Σ_i w_i ‖s·p_i − g_i‖₁; with trunc > 0 the truncated variant per coordinate.
ScaleFit fit_points_scale_l1(const at::Tensor& source, const at::Tensor& target,
                             const at::Tensor& weight, const at::Tensor& mask = {},
                             double trunc = 0.0);

// MoGe's training alignment (align_points_scale_z_shift with trunc): one scale and a z-only
// shift, min over (s, t_z) of Σ_i Σ_c min(trunc, w_i |s·p_ic + t_c − g_ic|), t = (0, 0, t_z).
// Not convex; some minimiser makes one sample's z residual vanish, so every sample is tried
// as that anchor with an exact truncated scale fit: O(n² log n), meant for GPU training
// batches. loss is the truncated objective.
AffineFit fit_points_scale_z_shift_l1_truncated(const at::Tensor& source, const at::Tensor& target,
                                                const at::Tensor& weight, double trunc,
                                                const at::Tensor& mask = {});

// Per-axis translation only: shift_c = argmin_t Σ_i w_i |p_ic + t − g_ic|. Returns (..., 3).
at::Tensor fit_points_shift_l1(const at::Tensor& source, const at::Tensor& target,
                               const at::Tensor& weight, const at::Tensor& mask = {});

// Scale + xyz shift, min Σ_i w_i ‖s·p_i + t − g_i‖₁ over (s, t), global optimum (the
// per-axis shifts are independent weighted medians for a fixed s). Fast solver as above.
AffineFit fit_points_affine_l1(const at::Tensor& source, const at::Tensor& target,
                               const at::Tensor& weight, const at::Tensor& mask = {});

// MoGe's evaluation variant of the scale + xyz-shift fit (the protocol's
// points_affine_invariant): the shift is restricted to make one sample point fit exactly,
// t = g_j − s·p_j, and the best anchor j wins. Exact for that restricted problem: anchors
// are pruned by convexity bounds computed for all of them at once, and only the survivors
// get an exact scale fit.
AffineFit fit_points_affine_l1_anchored(const at::Tensor& source, const at::Tensor& target,
                                        const at::Tensor& weight, const at::Tensor& mask = {});
// The same without pruning (MoGe's method, O(n² log n)); the reference for tests.
AffineFit fit_points_affine_l1_anchored_brute_force(const at::Tensor& source,
                                                    const at::Tensor& target,
                                                    const at::Tensor& weight,
                                                    const at::Tensor& mask = {});

}  // namespace omnipoint::geometry
