#pragma once
// The OmniPoint network (paper, "Method"): image + optional conditions -> for every pixel a
// unit ray r̂, a radial distance d̂ and a mask, plus one global metric scale ŝ; P = ŝ·d̂·r̂.
//
// Architecture: MoGe-2's DINOv2 encoder and uv-conditioned conv neck (model/moge2.h), with
// OmniPoint's heads on the neck — ray (3 ch), distance (1 ch), mask (1 ch), each a MoGe-2
// ConvStack whose level-4 output is resized to the input size before its activation — and the
// scale MLP on the class token. Conditioning (model/conditioning.h) enters the ViT as one
// additive offset of its input tokens: state embeddings on every token, the ray-map and
// sparse-depth encodings on the patch tokens.
//
// Output kinds: `ray_distance` (the paper's model) or `xyz` (the ablation: MoGe's points head
// with the exp remap; rays and distances are derived from the points).
//
// Weights: state_dict names follow the module names below (MoGe-2's where shared); files are
// safetensors with __metadata__ {"format": "omnipoint", "config": "<OmniPointConfig JSON>"}.
#include <ATen/core/Tensor.h>
#include <torch/nn/module.h>
#include <torch/nn/modules/container/sequential.h>
#include <torch/nn/modules/embedding.h>
#include <torch/nn/pimpl.h>

#include <cstdint>
#include <string>

#include "omnipoint/model/conditioning.h"
#include "omnipoint/model/conv_stack.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/omnipoint_config.h"

namespace omnipoint::model {

// The conditions of one forward pass; undefined tensors mean "absent for the whole batch".
// Per item presence follows conditioning.h (zero rays / no valid sample = absent).
// The conditions are optional: an undefined tensor means "not given".
struct OmniPointInputs {
  at::Tensor image;           // (B,3,H,W) RGB in [0,1]
  at::Tensor rays{};          // (B,3,H,W) unit rays of the camera at the pixel centres
  at::Tensor sparse_depth{};  // (B,H,W) radial distances, 0 / non-finite where no sample
};

struct OmniPointOutput {
  at::Tensor rays;          // (B,H,W,3) unit rays r̂
  at::Tensor distance;      // (B,H,W) radial distance d̂ > 0 (scale-invariant)
  at::Tensor points;        // (B,H,W,3) metric points ŝ·d̂·r̂
  at::Tensor mask;          // (B,H,W) probability in [0,1]
  at::Tensor metric_scale;  // (B) ŝ > 0
  // Pre-activation maps at the input size, for the training losses.
  at::Tensor ray_raw;           // (B,H,W,3) before normalisation (ray_distance)
  at::Tensor log_distance;      // (B,H,W) log d̂ (ray_distance)
  at::Tensor points_raw;        // (B,H,W,3) before the exp remap (xyz)
  at::Tensor mask_logits;       // (B,H,W)
  at::Tensor log_metric_scale;  // (B)
  // The condition state each item was run with.
  at::Tensor intrinsics_present;    // (B) bool
  at::Tensor sparse_depth_present;  // (B) bool
};

class OmniPointModelImpl : public torch::nn::Module {
 public:
  explicit OmniPointModelImpl(const OmniPointConfig& config);

  // num_tokens: the target number of ViT patch tokens (MoGe-2's token_grid); the image may
  // have any size, the ray map and sparse depth any size too (they are resampled to the ViT
  // input grid), with the image's batch size.
  OmniPointOutput forward(const OmniPointInputs& inputs, int64_t num_tokens);

  // The additive offset of the ViT input tokens (B, prefix + rows·cols, C; prefix = class and
  // register tokens) for these conditions: the state embeddings on every token, the branch
  // encodings on the patch tokens. Undefined when there is nothing to add (no state embeddings,
  // no condition tensors), so the tokens are then exactly MoGe-2's. Also each item's state.
  struct TokenConditioning {
    at::Tensor offset;
    at::Tensor intrinsics_present;
    at::Tensor sparse_depth_present;
  };
  TokenConditioning condition_tokens(const OmniPointInputs& inputs, const TokenGrid& grid);
  // The encoder with the conditions: projected features (B, dim_out, rows, cols) and the
  // class token, as MoGe2Encoder::forward but for the conditioned ViT input.
  EncoderOutput encode(const OmniPointInputs& inputs, const TokenGrid& grid,
                       TokenConditioning* conditioning = nullptr);

  const OmniPointConfig& config() const { return config_; }

  MoGe2Encoder encoder{nullptr};
  ConvStack neck{nullptr};
  ConvStack ray_head{nullptr};       // ray_distance
  ConvStack distance_head{nullptr};  // ray_distance
  ConvStack points_head{nullptr};    // xyz
  ConvStack mask_head{nullptr};
  torch::nn::Sequential scale_head{nullptr};
  torch::nn::Embedding intrinsics_state{nullptr};  // e_intrinsic
  torch::nn::Embedding depth_state{nullptr};       // e_depth
  ConditionEncoder intrinsics_encoder{nullptr};
  ConditionEncoder sparse_depth_encoder{nullptr};

 private:
  OmniPointConfig config_;
};
TORCH_MODULE(OmniPointModel);

// Whether a state_dict name belongs to a condition branch (the intrinsics and sparse-depth
// encoders and state embeddings), which a config may add or drop around the same network.
bool is_conditioning_tensor(const std::string& name);

}  // namespace omnipoint::model
