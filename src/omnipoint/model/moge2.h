#pragma once
// MoGe-2 (Wang et al. 2025), the network OmniPoint builds on, loadable from MoGe-2's own
// checkpoints (converted to safetensors) by name.
//
//   image (B,3,H,W) in [0,1], num_tokens
//     → token grid rows × cols with rows·cols ≈ num_tokens at the image's aspect
//     → encoder: resize to 14·(rows, cols), normalise, DINOv2, intermediate layers projected
//       (1×1) and summed                                   → (B, Cd, rows, cols) + class token
//     → neck: ConvStack fed with [features, uv] at level 0 and uv at levels 1–4
//     → heads: ConvStacks on the neck levels, read at level 4 = 16·(rows, cols)
//     → raw maps resized (bilinear) to H × W, then remapped: points (exp), mask (sigmoid),
//       normal (unit); metric scale = exp(MLP(class token))
// Names follow MoGe's v2.py: encoder.{image_mean,image_std,backbone,output_projections},
// neck, points_head, mask_head, normal_head, scale_head. Details: fixtures README §0–1.
#include <ATen/core/Tensor.h>
#include <torch/nn/module.h>
#include <torch/nn/modules/container/modulelist.h>
#include <torch/nn/modules/container/sequential.h>
#include <torch/nn/pimpl.h>
#include <nlohmann/json_fwd.hpp>

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "omnipoint/model/conv_stack.h"
#include "omnipoint/model/dinov2.h"

namespace omnipoint::model {

struct MoGe2EncoderConfig {
  std::string backbone = "dinov2_vitl14";    // a hub name or "dinov2_custom"
  DinoV2Config backbone_config;              // resolved from the name, or MoGe's backbone_config
  std::vector<int64_t> intermediate_layers;  // block indices (an int n in JSON: the last n)
  int64_t dim_out = 1024;
  // Read and written as MoGe-2's "encoder" section (also OmniPoint's) by moge2_encoder_table()
  // (model/config_tables.h); unknown keys pass, as MoGe's **deprecated_kwargs.
};

struct MoGe2Config {
  MoGe2EncoderConfig encoder;
  ConvStackConfig neck;
  std::optional<ConvStackConfig> points_head, mask_head, normal_head;
  std::vector<int64_t> scale_head_dims;  // empty: no metric scale head
  std::string remap_output = "linear";   // linear | sinh | exp | sinh_exp
  std::array<int64_t, 2> num_tokens_range{1200, 3600};

  // The dict MoGe-2's MoGeModel(**config) takes, as stored in our safetensors metadata (read
  // through moge2_table(), model/config_tables.h); std::invalid_argument
  // "MoGe-2 config: KEY: problem".
  static MoGe2Config from_json(const nlohmann::json& json);
  static MoGe2Config from_json_text(const std::string& text);
  // MoGe's infer() default: resolution level 0..9 spans num_tokens_range (9 = the maximum).
  int64_t default_num_tokens(int resolution_level = 9) const;
};

// The ViT patch grid for an image: rows·cols ≈ num_tokens at aspect W/H (README §1.2).
struct TokenGrid {
  int64_t rows = 0, cols = 0;
};
TokenGrid token_grid(int64_t height, int64_t width, int64_t num_tokens);

// Remaps a raw (…,3) point map: "exp" → (a·e^c, b·e^c, e^c); "sinh" → sinh(·);
// "sinh_exp" → (sinh a, sinh b, e^c); "linear" → unchanged.
at::Tensor remap_points(const at::Tensor& raw, const std::string& remap);

// Shared by MoGe-2 and OmniPoint (model/omnipoint_model.h):
// the neck's inputs (README §1.4–1.5): [features, uv] at level 0, the uv map at levels ≥ 1,
// the uv map at 2^l times the grid for an image of aspect W/H `aspect_ratio`;
std::vector<at::Tensor> neck_inputs(const at::Tensor& features, const TokenGrid& grid,
                                    double aspect_ratio, int64_t num_levels);
// a raw (B,C,h,w) head map resized to the (B,3,H,W) image's size (bilinear, align_corners
// false, no antialias), before any activation: interpolating exp(z) is not exp(interpolated
// z); in the image's precision, so under autocast (precision.h) what follows is not 16-bit;
at::Tensor resize_to_image(const at::Tensor& map, const at::Tensor& image);
// the same as a contiguous (B,H,W,C) map, for the per-pixel vectors (points, rays, normals)
// the geometry after the network reads: a reduction over the last dimension of the permuted
// view (a ray's norm) took ~40x as long at 12 MP;
at::Tensor resize_to_image_channels_last(const at::Tensor& map, const at::Tensor& image);
// the scale head: Linear layers over `dims` with a ReLU between consecutive ones;
torch::nn::Sequential scale_mlp(const std::vector<int64_t>& dims);
// its (B) log scale from the (B,C) class token, in full precision (autocast off): the one
// number per image that scales every point.
at::Tensor log_metric_scale(torch::nn::Sequential& scale_head, const at::Tensor& class_token,
                            c10::ScalarType dtype);

struct EncoderOutput {
  at::Tensor features;     // (B, dim_out, rows, cols): the projected intermediate layers, summed
  at::Tensor class_token;  // (B, C): of the last intermediate layer, after the final norm
};

class MoGe2EncoderImpl : public torch::nn::Module {
 public:
  explicit MoGe2EncoderImpl(const MoGe2EncoderConfig& config);
  // Anti-aliased bilinear resize to 14·(rows, cols), then ImageNet normalisation.
  at::Tensor preprocess(const at::Tensor& image, const TokenGrid& grid) const;
  // Projects and sums backbone layers (as returned by DinoV2::forward) on the grid.
  EncoderOutput project(const std::vector<DinoV2Layer>& layers, const TokenGrid& grid);
  EncoderOutput forward(const at::Tensor& image, const TokenGrid& grid);

  const MoGe2EncoderConfig& config() const { return config_; }

  at::Tensor image_mean, image_std;  // buffers (1,3,1,1)
  DinoV2 backbone{nullptr};
  torch::nn::ModuleList output_projections{nullptr};

 private:
  MoGe2EncoderConfig config_;
};
TORCH_MODULE(MoGe2Encoder);

// Head maps at 16·(rows, cols), before resizing and remapping.
struct MoGe2RawOutput {
  at::Tensor points;     // (B,3,h,w)
  at::Tensor mask;       // (B,1,h,w) logits, undefined without a mask head
  at::Tensor normal;     // (B,3,h,w), undefined without a normal head
  at::Tensor log_scale;  // (B), undefined without a scale head
  at::Tensor projected;  // (B,dim_out,rows,cols): the encoder's features
};

struct MoGe2Output {
  at::Tensor points;        // (B,H,W,3) affine-invariant point map
  at::Tensor mask;          // (B,H,W) probability; undefined without a mask head
  at::Tensor normal;        // (B,H,W,3) unit normals; undefined without a normal head
  at::Tensor metric_scale;  // (B); undefined without a scale head
};

class MoGe2ModelImpl : public torch::nn::Module {
 public:
  explicit MoGe2ModelImpl(const MoGe2Config& config);

  // Raw head maps for an image on the given token grid.
  MoGe2RawOutput forward_raw(const at::Tensor& image, const TokenGrid& grid);
  // image (B,3,H,W) in [0,1]; num_tokens: target number of patch tokens.
  MoGe2Output forward(const at::Tensor& image, int64_t num_tokens);

  const MoGe2Config& config() const { return config_; }

  MoGe2Encoder encoder{nullptr};
  ConvStack neck{nullptr};
  ConvStack points_head{nullptr}, mask_head{nullptr}, normal_head{nullptr};
  torch::nn::Sequential scale_head{nullptr};  // Linear, ReLU, …, Linear

 private:
  MoGe2Config config_;
};
TORCH_MODULE(MoGe2Model);

// A MoGe-2 model from the content of a weights file: the config is the metadata entry
// "config" (a "format" entry, if present, must be "moge2"); the tensors load strictly, shared
// as load_omnipoint_model shares them.
// std::invalid_argument for a bad or missing config, std::runtime_error (listing the
// names) for weights that do not fit it.
MoGe2Model load_moge2(const std::map<std::string, at::Tensor>& tensors,
                      const std::map<std::string, std::string>& metadata);

}  // namespace omnipoint::model
