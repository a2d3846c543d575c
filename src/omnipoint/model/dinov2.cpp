#include "omnipoint/model/dinov2.h"

#include <ATen/ATen.h>
#include <torch/nn/functional/upsampling.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "omnipoint/model/config_tables.h"

namespace omnipoint::model {

namespace F = torch::nn::functional;

DinoV2Config DinoV2Config::hub(const std::string& name) {
  DinoV2Config config;
  if (name == "dinov2_vits14") {
    config.embed_dim = 384, config.depth = 12, config.num_heads = 6;
  } else if (name == "dinov2_vitb14") {
    config.embed_dim = 768, config.depth = 12, config.num_heads = 12;
  } else if (name == "dinov2_vitl14") {
    config.embed_dim = 1024, config.depth = 24, config.num_heads = 16;
  } else if (name == "dinov2_vitg14") {
    config.embed_dim = 1536, config.depth = 40, config.num_heads = 24;
    config.ffn_layer = "swiglufused";
  } else {
    throw std::invalid_argument("unknown DINOv2 backbone '" + name +
                                "' (expected dinov2_vits14, dinov2_vitb14, dinov2_vitl14, "
                                "dinov2_vitg14 or dinov2_custom with a backbone_config)");
  }
  return config;
}

const util::ConfigTable<DinoV2Config>& dinov2_table() {
  static const util::ConfigTable<DinoV2Config> table = [] {
    util::ConfigTable<DinoV2Config> t;
    t.field("embed_dim", &DinoV2Config::embed_dim).positive();
    // The largest published ViT has 40 blocks; the bound keeps a config from allocating
    // what no file of weights could fill.
    t.field("depth", &DinoV2Config::depth).range(1, 1024);
    t.field("num_heads", &DinoV2Config::num_heads).positive();
    t.field("mlp_ratio", &DinoV2Config::mlp_ratio).positive();
    t.field("img_size", &DinoV2Config::img_size);
    t.field("patch_size", &DinoV2Config::patch_size).positive();
    t.field("ffn_layer", &DinoV2Config::ffn_layer, "mlp (GELU) or swiglufused (ViT-G)")
        .check(
            [](const std::string& layer) {
              return layer == "mlp" || layer == "swiglufused" || layer == "swiglu";
            },
            "is not supported (expected mlp or swiglufused)");
    // DINOv2's None (no LayerScale) is 0 here.
    util::ConfigCodec<double> init_values = util::double_codec();
    init_values.read = [finite = init_values.read](const nlohmann::json& json,
                                                   const util::ConfigScope& scope) {
      return json.is_null() ? 0.0 : finite(json, scope);
    };
    t.field("init_values", &DinoV2Config::init_values, init_values,
            "LayerScale's initial value; null or 0: no LayerScale");
    t.field("num_register_tokens", &DinoV2Config::num_register_tokens).at_least(0);
    t.field("interpolate_offset", &DinoV2Config::interpolate_offset);
    t.field("interpolate_antialias", &DinoV2Config::interpolate_antialias);
    t.field("qkv_bias", &DinoV2Config::qkv_bias);
    t.field("proj_bias", &DinoV2Config::proj_bias);
    t.field("ffn_bias", &DinoV2Config::ffn_bias);
    t.field("layer_norm_eps", &DinoV2Config::layer_norm_eps);
    t.constant("act", "gelu");
    // Chunked blocks only regroup the state-dict names (blocks.chunk.N); not supported.
    t.constant("block_chunks", int64_t{0});
    t.rule([](const DinoV2Config& config, const util::ConfigScope& scope) {
      if (config.num_heads > 0 && config.embed_dim % config.num_heads != 0)
        scope.key("embed_dim").fail("must be a multiple of num_heads");
      if (config.img_size < config.patch_size)
        scope.key("img_size").fail("must be at least patch_size");
    });
    return t;
  }();
  return table;
}

DinoV2Config DinoV2Config::from_json(const nlohmann::json& json) {
  return util::read_config(dinov2_table(), json, "DINOv2 config");
}

void DinoV2Config::validate() const {
  util::check_config(dinov2_table(), *this, "DINOv2 config");
}

LayerScaleImpl::LayerScaleImpl(int64_t dim, double init_values) {
  gamma = register_parameter("gamma", at::full({dim}, init_values));
}

AttentionImpl::AttentionImpl(int64_t dim, int64_t num_heads, bool qkv_bias, bool proj_bias)
    : num_heads_(num_heads) {
  qkv = register_module("qkv", Linear(torch::nn::LinearOptions(dim, 3 * dim).bias(qkv_bias)));
  proj = register_module("proj", Linear(torch::nn::LinearOptions(dim, dim).bias(proj_bias)));
}

at::Tensor AttentionImpl::forward(const at::Tensor& x) {
  const int64_t batch = x.size(0), tokens = x.size(1), dim = x.size(2);
  const int64_t head_dim = dim / num_heads_;
  // qkv channels are [q | k | v], heads contiguous inside each: (B,N,3,heads,hd).
  const at::Tensor qkv_heads =
      qkv(x).view({batch, tokens, 3, num_heads_, head_dim}).permute({2, 0, 3, 1, 4});
  // (B·heads, N, hd); the 1/sqrt(hd) scale is folded into q (one N·hd multiply, not N²).
  const at::Tensor q = (qkv_heads[0] * (1.0 / std::sqrt(static_cast<double>(head_dim))))
                           .reshape({batch * num_heads_, tokens, head_dim});
  const at::Tensor k = qkv_heads[1].reshape({batch * num_heads_, tokens, head_dim});
  const at::Tensor v = qkv_heads[2].reshape({batch * num_heads_, tokens, head_dim});
  // The N×N score matrices dominate memory at high token counts (ViT-L, 2,400 tokens: 369 MB
  // for all heads); heads are processed in groups whose scores stay within a fixed budget.
  constexpr int64_t kScoreBudget = int64_t{1} << 25;  // elements (128 MB in float32)
  const int64_t batch_heads = batch * num_heads_;
  const int64_t group = std::clamp<int64_t>(kScoreBudget / (tokens * tokens), 1, batch_heads);
  std::vector<at::Tensor> groups;
  for (int64_t start = 0; start < batch_heads; start += group) {
    const int64_t size = std::min(group, batch_heads - start);
    const at::Tensor scores =
        at::bmm(q.narrow(0, start, size), k.narrow(0, start, size).transpose(1, 2));
    groups.push_back(at::bmm(at::softmax(scores, -1), v.narrow(0, start, size)));
  }
  const at::Tensor heads = groups.size() == 1 ? groups[0] : at::cat(groups, 0);  // (B·heads, N, hd)
  return proj(heads.view({batch, num_heads_, tokens, head_dim})
                  .transpose(1, 2)
                  .reshape({batch, tokens, dim}));
}

FeedForwardImpl::FeedForwardImpl(const DinoV2Config& config) {
  const int64_t dim = config.embed_dim;
  const auto hidden = static_cast<int64_t>(static_cast<double>(dim) * config.mlp_ratio);
  if (config.ffn_layer == "mlp") {
    fc1 =
        register_module("fc1", Linear(torch::nn::LinearOptions(dim, hidden).bias(config.ffn_bias)));
    fc2 =
        register_module("fc2", Linear(torch::nn::LinearOptions(hidden, dim).bias(config.ffn_bias)));
  } else {
    // DINOv2's SwiGLUFFNFused: hidden = 2/3 of the MLP width, rounded up to a multiple of 8.
    const int64_t swiglu_hidden = (hidden * 2 / 3 + 7) / 8 * 8;
    w12 = register_module(
        "w12", Linear(torch::nn::LinearOptions(dim, 2 * swiglu_hidden).bias(config.ffn_bias)));
    w3 = register_module(
        "w3", Linear(torch::nn::LinearOptions(swiglu_hidden, dim).bias(config.ffn_bias)));
  }
}

at::Tensor FeedForwardImpl::forward(const at::Tensor& x) {
  if (fc1) return fc2(at::gelu(fc1(x)));  // exact erf GELU
  const auto gate_value = w12(x).chunk(2, -1);
  return w3(at::silu(gate_value[0]) * gate_value[1]);
}

BlockImpl::BlockImpl(const DinoV2Config& config) {
  const int64_t dim = config.embed_dim;
  const auto norm_options = torch::nn::LayerNormOptions({dim}).eps(config.layer_norm_eps);
  norm1 = register_module("norm1", torch::nn::LayerNorm(norm_options));
  attn =
      register_module("attn", Attention(dim, config.num_heads, config.qkv_bias, config.proj_bias));
  if (config.init_values > 0) ls1 = register_module("ls1", LayerScale(dim, config.init_values));
  norm2 = register_module("norm2", torch::nn::LayerNorm(norm_options));
  mlp = register_module("mlp", FeedForward(config));
  if (config.init_values > 0) ls2 = register_module("ls2", LayerScale(dim, config.init_values));
}

at::Tensor BlockImpl::forward(const at::Tensor& x) {
  // x + gamma ⊙ f(x) as one fused addcmul per branch.
  at::Tensor attended = attn(norm1(x));
  at::Tensor y = ls1 ? at::addcmul(x, attended, ls1->gamma) : x + attended;
  at::Tensor fed = mlp(norm2(y));
  return ls2 ? at::addcmul(y, fed, ls2->gamma) : y + fed;
}

PatchEmbedImpl::PatchEmbedImpl(int64_t patch_size, int64_t embed_dim) {
  proj = register_module(
      "proj", Conv2d(torch::nn::Conv2dOptions(3, embed_dim, patch_size).stride(patch_size)));
}

DinoV2Impl::DinoV2Impl(const DinoV2Config& config) : config_(config) {
  config_.validate();
  const int64_t dim = config_.embed_dim;
  const int64_t grid = config_.grid_size();
  patch_embed = register_module("patch_embed", PatchEmbed(config_.patch_size, dim));
  cls_token = register_parameter("cls_token", at::zeros({1, 1, dim}));
  pos_embed = register_parameter("pos_embed", at::zeros({1, 1 + grid * grid, dim}));
  if (config_.num_register_tokens > 0)
    register_tokens =
        register_parameter("register_tokens", at::zeros({1, config_.num_register_tokens, dim}));
  mask_token = register_parameter("mask_token", at::zeros({1, dim}));
  blocks = register_module("blocks", torch::nn::ModuleList());
  for (int64_t i = 0; i < config_.depth; ++i) blocks->push_back(Block(config_));
  norm = register_module(
      "norm", torch::nn::LayerNorm(torch::nn::LayerNormOptions({dim}).eps(config_.layer_norm_eps)));
}

at::Tensor DinoV2Impl::position_embedding(int64_t rows, int64_t cols) const {
  const int64_t grid = config_.grid_size();
  if (rows == grid && cols == grid) return pos_embed;
  const int64_t dim = config_.embed_dim;
  const at::Tensor table = pos_embed.to(at::kFloat);
  const at::Tensor patch_grid =
      table.narrow(1, 1, grid * grid).reshape({1, grid, grid, dim}).permute({0, 3, 1, 2});
  auto options = F::InterpolateFuncOptions()
                     .mode(torch::kBicubic)
                     .align_corners(false)
                     .antialias(config_.interpolate_antialias);
  if (config_.interpolate_offset != 0) {
    // DINOv2 passes scale factors, and the kernel samples at (i + 0.5) / s - 0.5 with them;
    // resizing to the size instead samples elsewhere (off by up to 2 on the fixture).
    // (recompute_scale_factor false = PyTorch's default behaviour, stated to silence its warning.)
    options
        .scale_factor(
            std::vector<double>{(static_cast<double>(rows) + config_.interpolate_offset) / grid,
                                (static_cast<double>(cols) + config_.interpolate_offset) / grid})
        .recompute_scale_factor(false);
  } else {
    options.size(std::vector<int64_t>{rows, cols});
  }
  const at::Tensor resized = F::interpolate(patch_grid, options);
  TORCH_CHECK(resized.size(2) == rows && resized.size(3) == cols, "position embedding resized to ",
              resized.sizes(), ", expected ", rows, "x", cols);
  const at::Tensor patch_entries = resized.permute({0, 2, 3, 1}).reshape({1, rows * cols, dim});
  return at::cat({table.narrow(1, 0, 1), patch_entries}, 1).to(pos_embed.scalar_type());
}

at::Tensor DinoV2Impl::prepare_tokens(const at::Tensor& image) {
  const int64_t patch = config_.patch_size;
  if (image.dim() != 4 || image.size(1) != 3 || image.size(2) % patch != 0 ||
      image.size(3) % patch != 0) {
    throw std::invalid_argument("DINOv2 input must be (B,3,H,W) with H and W multiples of " +
                                std::to_string(patch) + ", got " + c10::str(image.sizes()));
  }
  const int64_t batch = image.size(0), rows = image.size(2) / patch, cols = image.size(3) / patch;
  const at::Tensor patches =
      patch_embed->forward(image).flatten(2).transpose(1, 2);  // (B, rows·cols, C)
  at::Tensor tokens = at::cat({cls_token.expand({batch, 1, config_.embed_dim}), patches}, 1);
  tokens = tokens + position_embedding(rows, cols);
  if (register_tokens.defined()) {
    tokens = at::cat({tokens.narrow(1, 0, 1), register_tokens.expand({batch, -1, -1}),
                      tokens.narrow(1, 1, rows * cols)},
                     1);
  }
  return tokens;
}

std::vector<DinoV2Layer> DinoV2Impl::intermediate_layers(at::Tensor tokens,
                                                         const std::vector<int64_t>& layers) {
  for (size_t i = 0; i < layers.size(); ++i) {
    if (layers[i] < 0 || layers[i] >= config_.depth || (i > 0 && layers[i] <= layers[i - 1])) {
      throw std::invalid_argument(
          "DINOv2 intermediate layers must be increasing block indices in [0, " +
          std::to_string(config_.depth) + ")");
    }
  }
  std::vector<DinoV2Layer> outputs;
  const int64_t prefix = num_prefix_tokens();
  const int64_t last = layers.empty() ? -1 : layers.back();
  for (int64_t b = 0, next = 0; b <= last; ++b) {
    tokens = blocks->ptr<BlockImpl>(b)->forward(tokens);
    if (b != layers[next]) continue;
    const at::Tensor normed = norm(tokens);
    outputs.push_back({normed.narrow(1, prefix, normed.size(1) - prefix), normed.select(1, 0)});
    ++next;
  }
  return outputs;
}

std::vector<DinoV2Layer> DinoV2Impl::forward(const at::Tensor& image,
                                             const std::vector<int64_t>& layers) {
  return intermediate_layers(prepare_tokens(image), layers);
}

}  // namespace omnipoint::model
