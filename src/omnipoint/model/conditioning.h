#pragma once
// OmniPoint's optional geometric inputs (paper, "Optional Geometric Inputs"):
// - input-state embeddings e_intrinsic / e_depth: a learned (absent, present) pair of vectors,
//   added to every token entering the ViT;
// - the intrinsics branch: the per-pixel unit-ray map of ANY camera model -> a lightweight
//   conv encoder -> added to the patch embeddings;
// - the sparse-depth branch: depth normalised by its valid mean, densified by Gaussian
//   splatting, with the sample mask [D_smooth, M] -> a conv encoder -> added to the patch
//   embeddings.
// (The post-alignment of the metric scale to metric sparse depth is
// geometry::fit_scale_to_sparse_depth, applied by infer::run.)
//
// Conventions. A condition is given per batch item, and an item's condition is present when it
// holds any valid value: a ray map (B,3,H,W) is valid where the ray is finite and non-zero
// (cameras give zero rays outside their domain; non-finite rays are treated as zero), a sparse
// depth map (B,H,W) holds radial distances along the pixel's ray (docs/DESIGN.md: distance, not
// planar z) and is valid where finite and > 0. Absent items may therefore be stacked as zeros into a mixed batch. Every fusion layer (the encoders'
// last conv, the state embeddings) starts at zero, so a model initialised from MoGe-2 starts out
// computing exactly MoGe-2's features.
#include <ATen/core/Tensor.h>
#include <torch/nn/module.h>
#include <torch/nn/modules/embedding.h>
#include <torch/nn/pimpl.h>

#include <cstdint>

#include "omnipoint/model/layers.h"

namespace omnipoint::model {

struct ConditioningConfig {
  bool intrinsics = true;          // the ray-map branch exists
  bool sparse_depth = true;        // the sparse-depth branch exists
  bool state_embeddings = true;    // e_intrinsic / e_depth (for the branches that exist)
  bool gaussian_smoothing = true;  // densify sparse depth; off: the normalised samples as they are
  int64_t splat_radius = 7;        // r, pixels of the ViT input grid
  double splat_sigma_per_depth = 3.0;  // sigma [px] of a sample at the mean depth (σ ∝ depth)
  double splat_min_sigma = 1.0;        // lower bound of sigma [px]
  int64_t encoder_dim = 64;            // hidden channels of the condition encoders
};

// Per-item presence (B,) bool of each condition, following the conventions above.
at::Tensor rays_present(const at::Tensor& rays);                // rays (B,3,H,W)
at::Tensor valid_rays(const at::Tensor& rays);                  // non-finite rays zeroed
at::Tensor sparse_depth_valid(const at::Tensor& sparse_depth);  // (B,H,W) bool
at::Tensor sparse_depth_present(const at::Tensor& sparse_depth);

// e_intrinsic / e_depth: a torch::nn::Embedding(2, C) indexed by presence (row 0 absent,
// row 1 present), zero-initialised; (B,) bool -> (B,1,C), broadcast over the tokens.
torch::nn::Embedding make_state_embedding(int64_t embed_dim);
at::Tensor state_embedding(torch::nn::Embedding& embedding, const at::Tensor& present);

// Patchify conv (kernel = stride = ViT patch size) -> GELU -> 1x1 fusion conv (zero-initialised):
// (B,in,14·rows,14·cols) -> patch-token offsets (B, rows·cols, C), row-major token order.
class ConditionEncoderImpl : public torch::nn::Module {
 public:
  ConditionEncoderImpl(int64_t in_channels, int64_t hidden_dim, int64_t embed_dim,
                       int64_t patch_size);
  at::Tensor forward(const at::Tensor& x);

  Conv2d patchify{nullptr};
  Conv2d fuse{nullptr};
};
TORCH_MODULE(ConditionEncoder);

// The sparse-depth branch's input at a target grid (the ViT input size): the sparse map
// (B,H,W) is moved to the grid (each sample to the grid pixel holding its centre; samples
// sharing a pixel are averaged), normalised by each item's valid mean and Gaussian-splatted
// (geometry::splat_sparse_depth; without smoothing the radius is 0, which leaves the
// normalised samples). Returns (B,2,h,w) = [D_smooth, M]; items without samples are zero.
at::Tensor sparse_depth_features(const at::Tensor& sparse_depth, int64_t height, int64_t width,
                                 const ConditioningConfig& config);

}  // namespace omnipoint::model
