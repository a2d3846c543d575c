#pragma once
// DINOv2 vision transformer (Oquab et al. 2023), the encoder of MoGe-2 and OmniPoint.
//
// One class for every size (ViT-S/B/L/G, tiny test models), configured by DinoV2Config.
// Submodule and parameter names equal the DINOv2 / MoGe-2 checkpoint names
// (`patch_embed.proj`, `cls_token`, `pos_embed`, `mask_token`, `register_tokens`,
// `blocks.N.{norm1,attn.qkv,attn.proj,ls1.gamma,norm2,mlp.fc1,mlp.fc2,ls2.gamma}`, `norm`),
// so a checkpoint loads strictly by name.
//
// Conventions: images are NCHW with H and W multiples of the patch size; token sequences
// are (B, N, C) with the class token first, then the register tokens, then the patch tokens
// in row-major order (token = row·cols + col). The learned position embedding covers a
// square grid (img_size / patch_size)² and is resized bicubically to the actual grid the
// way DINOv2 does it (scale factors (rows + offset) / grid, not sizes; fixtures README §1.3).
#include <ATen/core/Tensor.h>
#include <torch/nn/module.h>
#include <torch/nn/modules/container/modulelist.h>
#include <torch/nn/modules/normalization.h>
#include <torch/nn/pimpl.h>
#include <nlohmann/json_fwd.hpp>

#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/model/layers.h"

namespace omnipoint::model {

struct DinoV2Config {
  int64_t embed_dim = 1024;
  int64_t depth = 24;
  int64_t num_heads = 16;
  double mlp_ratio = 4.0;
  int64_t img_size = 518;
  int64_t patch_size = 14;
  std::string ffn_layer = "mlp";  // "mlp" (GELU) or "swiglufused" (ViT-G)
  double init_values = 1.0;       // LayerScale present iff > 0
  int64_t num_register_tokens = 0;
  double interpolate_offset = 0.1;
  bool interpolate_antialias = false;
  bool qkv_bias = true;
  bool proj_bias = true;
  bool ffn_bias = true;
  double layer_norm_eps = 1e-6;

  // The torch.hub backbones by name: dinov2_vits14, dinov2_vitb14, dinov2_vitl14, dinov2_vitg14.
  static DinoV2Config hub(const std::string& name);
  // DINOv2's constructor keywords (MoGe's `backbone_config`); unknown keys are an error. The
  // table of keys and checks is dinov2_table() (model/config_tables.h).
  static DinoV2Config from_json(const nlohmann::json& json);

  int64_t head_dim() const { return embed_dim / num_heads; }
  int64_t grid_size() const { return img_size / patch_size; }  // side of the pos-embed grid
  void validate() const;                                       // std::invalid_argument if bad
};

// The patch tokens and the class token of one block's output, after the final LayerNorm.
struct DinoV2Layer {
  at::Tensor patch_tokens;  // (B, rows·cols, C)
  at::Tensor class_token;   // (B, C)
};

class LayerScaleImpl : public torch::nn::Module {
 public:
  explicit LayerScaleImpl(int64_t dim, double init_values);
  at::Tensor forward(const at::Tensor& x) const { return x * gamma; }
  at::Tensor gamma;
};
TORCH_MODULE(LayerScale);

class AttentionImpl : public torch::nn::Module {
 public:
  AttentionImpl(int64_t dim, int64_t num_heads, bool qkv_bias, bool proj_bias);
  at::Tensor forward(const at::Tensor& x);
  Linear qkv{nullptr};
  Linear proj{nullptr};

 private:
  int64_t num_heads_;
};
TORCH_MODULE(Attention);

// fc2(GELU(fc1(x))) with the exact (erf) GELU, or SwiGLU (w12, w3) for ViT-G.
class FeedForwardImpl : public torch::nn::Module {
 public:
  FeedForwardImpl(const DinoV2Config& config);
  at::Tensor forward(const at::Tensor& x);
  Linear fc1{nullptr}, fc2{nullptr};  // "mlp"
  Linear w12{nullptr}, w3{nullptr};   // "swiglufused"
};
TORCH_MODULE(FeedForward);

// Pre-norm transformer block: x += ls1(attn(norm1(x))); x += ls2(mlp(norm2(x))).
class BlockImpl : public torch::nn::Module {
 public:
  explicit BlockImpl(const DinoV2Config& config);
  at::Tensor forward(const at::Tensor& x);
  torch::nn::LayerNorm norm1{nullptr}, norm2{nullptr};
  Attention attn{nullptr};
  FeedForward mlp{nullptr};
  LayerScale ls1{nullptr}, ls2{nullptr};  // null without LayerScale
};
TORCH_MODULE(Block);

class PatchEmbedImpl : public torch::nn::Module {
 public:
  PatchEmbedImpl(int64_t patch_size, int64_t embed_dim);
  at::Tensor forward(const at::Tensor& image) { return proj(image); }  // (B,C,rows,cols)
  Conv2d proj{nullptr};
};
TORCH_MODULE(PatchEmbed);

class DinoV2Impl : public torch::nn::Module {
 public:
  explicit DinoV2Impl(const DinoV2Config& config);

  // The position embedding added for a rows × cols patch grid: (1, 1 + rows·cols, C), the
  // class entry first. Computed in float32 as DINOv2 does, returned in the parameter dtype.
  at::Tensor position_embedding(int64_t rows, int64_t cols) const;
  // The tokens entering block 0: [cls; registers; patches] + position embedding (registers
  // get none). `image` is normalised, (B,3,14·rows,14·cols).
  at::Tensor prepare_tokens(const at::Tensor& image);
  // Runs the blocks on prepared tokens and returns the outputs of the requested blocks
  // (0-based, increasing), each passed through the final LayerNorm. Stops after the last one.
  std::vector<DinoV2Layer> intermediate_layers(at::Tensor tokens,
                                               const std::vector<int64_t>& layers);
  // prepare_tokens followed by intermediate_layers.
  std::vector<DinoV2Layer> forward(const at::Tensor& image, const std::vector<int64_t>& layers);

  const DinoV2Config& config() const { return config_; }
  int64_t num_prefix_tokens() const { return 1 + config_.num_register_tokens; }

  PatchEmbed patch_embed{nullptr};
  at::Tensor cls_token;        // (1,1,C)
  at::Tensor pos_embed;        // (1,1+grid²,C)
  at::Tensor mask_token;       // (1,C), used only by DINOv2's masked pre-training
  at::Tensor register_tokens;  // (1,R,C), undefined without registers
  torch::nn::ModuleList blocks{nullptr};
  torch::nn::LayerNorm norm{nullptr};

 private:
  DinoV2Config config_;
};
TORCH_MODULE(DinoV2);

}  // namespace omnipoint::model
