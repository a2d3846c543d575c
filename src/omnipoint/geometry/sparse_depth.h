#pragma once
// Densification of sparse depth for the model's sparse-depth branch (paper, Sec. "Robust
// Geometric Injection"): normalise by the mean of the valid values, then Gaussian splatting
// accumulated by scatter-add, D_smooth = Σ wᵢ Sᵢ / Σ wᵢ, plus the mask M of the samples.
//
// Conventions: depth maps are (..., H, W), any floating dtype, any device; the leading
// dimensions are batch dimensions and every item is processed on its own. A sample at
// pixel (col u, row v) spreads the weight w = exp(−(Δu² + Δv²) / (2σ²)) to the pixels of the
// disc Δu² + Δv² ≤ r² around it. The paper fixes r and makes σ proportional to the depth
// magnitude but gives no constants; ours: σ = clamp(sigma_per_depth · |Sᵢ / mean|, min_sigma,
// r) pixels, i.e. sigma_per_depth pixels at the mean depth, never wider than the disc.
#include <ATen/core/Tensor.h>

#include <cstdint>

namespace omnipoint::geometry {

struct SplatOptions {
  std::int64_t radius = 7;       // r in pixels: the kernel's disc
  double sigma_per_depth = 3.0;  // σ in pixels for a sample at the mean depth
  double min_sigma = 1.0;        // lower bound of σ in pixels (near / tiny values)
};

struct SplattedDepth {
  at::Tensor smooth;   // (..., H, W) D_smooth of the normalised depth; 0 where no weight
  at::Tensor mask;     // (..., H, W) M: 1 at the original samples, 0 elsewhere (input dtype)
  at::Tensor covered;  // (..., H, W) bool: Σ w > 0 (some sample's disc reaches the pixel)
  at::Tensor scale;    // (...)       mean of |S| over the valid samples; 1 for empty items
};

// Densifies sparse depth `sparse` (..., H, W). `valid` (..., H, W, bool) marks the samples;
// when undefined, the finite non-zero values are the samples (zero = missing). Invalid or
// non-finite entries never contribute. Items without samples give smooth = mask = 0 and
// scale = 1 (no NaN). Vectorised: one scatter-add pass per chunk of kernel offsets, no
// per-sample host loop. The result does not require grad.
SplattedDepth splat_sparse_depth(const at::Tensor& sparse, const at::Tensor& valid = {},
                                 const SplatOptions& options = {});

}  // namespace omnipoint::geometry
