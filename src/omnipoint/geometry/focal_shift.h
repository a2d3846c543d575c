#pragma once
// Focal length and z-shift of an affine-invariant point map (MoGe's recover_focal_shift).
//
// A network that predicts points only up to an unknown z-shift s and an unknown pinhole
// focal f (centred principal point, square pixels) is made metric-consistent by choosing
// s so that the shifted points project best onto the pixel grid:
//   p_i(s) = xy_i / (z_i + s),  f(s) = Σ p·uv / Σ p·p,  minimise Σ ‖f(s)·p_i − uv_i‖²,
// where uv are normalised view-plane coordinates (geometry/view_plane_uv.h), so f is
// relative to half the image diagonal. The fit uses a 64×64 nearest-neighbour subsample.
#include <ATen/core/Tensor.h>

#include <cstdint>

namespace omnipoint::geometry {

struct FocalShiftOptions {
  int64_t subsample_size = 64;  // side of the nearest-neighbour subsample
  // Gauss-Newton stopping rule of MINPACK's LM (scipy least_squares(method='lm',
  // ftol=1e-3)), which MoGe uses: stop once the actual and the predicted relative decrease
  // of the sum of squares are both <= ftol. Replaying it reproduces MoGe's (loose) shift.
  double ftol = 1e-3;
  int64_t max_iterations = 100;
};

struct FocalShift {
  at::Tensor focal;  // (B), relative to half the image diagonal
  at::Tensor shift;  // (B), added to z
};

// points: (B,H,W,3) affine point map; mask: (B,H,W) bool or undefined (all valid). Images
// with fewer than 2 valid samples get focal 1 and shift 0. Solved per image in float64 on
// the points' device; results in the points' dtype (the shift is rounded to it before the
// focal is evaluated, as MoGe does).
FocalShift recover_focal_shift(const at::Tensor& points, const at::Tensor& mask,
                               const FocalShiftOptions& options = {});

// Normalised pinhole intrinsics (B,3,3) — fx = f_px/W, fy = f_px/H, principal point (0.5, 0.5)
// — of a focal relative to half the diagonal of an image of aspect W/H.
at::Tensor intrinsics_from_focal(const at::Tensor& focal, double aspect_ratio);

// Points (B,H,W,3) of a depth map (B,H,W) seen through normalised pinhole intrinsics (B,3,3,
// zero skew),
// at the pixel centres u = (j+0.5)/W, v = (i+0.5)/H: depth · K⁻¹ [u, v, 1]ᵀ.
at::Tensor depth_to_points(const at::Tensor& depth, const at::Tensor& intrinsics);

}  // namespace omnipoint::geometry
