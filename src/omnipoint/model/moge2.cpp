#include "omnipoint/model/moge2.h"

#include <ATen/ATen.h>
#include <torch/nn/functional/upsampling.h>
#include <torch/nn/modules/activation.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <stdexcept>

#include "omnipoint/geometry/view_plane_uv.h"
#include "omnipoint/model/config_tables.h"
#include "omnipoint/model/layers.h"
#include "omnipoint/model/precision.h"
#include "omnipoint/model/state_dict.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::model {

namespace F = torch::nn::functional;

// ---------------------------------------------------------------------------------------------
// Configuration

namespace {

bool custom_backbone(const MoGe2EncoderConfig& config) {
  return config.backbone == "dinov2_custom";
}

}  // namespace

void check_neck_inputs(const MoGe2EncoderConfig& encoder, const ConvStackConfig& neck,
                       const util::ConfigScope& scope) {
  const util::ConfigScope dim_in = scope.key("neck").key("dim_in");
  if (!neck.dim_in[0] || *neck.dim_in[0] != encoder.dim_out + 2)
    dim_in.index(0).fail("must be encoder.dim_out + 2 (features and uv)");
  for (std::size_t level = 1; level < neck.dim_in.size(); ++level)
    if (neck.dim_in[level] && *neck.dim_in[level] != 2)
      dim_in.index(level).fail("levels above 0 take the 2-channel uv map (dim_in 2 or null)");
}

void check_scale_head(const std::vector<int64_t>& dims, const MoGe2EncoderConfig& encoder,
                      const util::ConfigScope& scope) {
  if (dims.size() < 2 || dims.front() != encoder.backbone_config.embed_dim || dims.back() != 1)
    scope.key("scale_head")
        .key("dims")
        .fail("must run from the ViT width (" + std::to_string(encoder.backbone_config.embed_dim) +
              ") to 1");
}

const util::ConfigTable<MoGe2EncoderConfig>& moge2_encoder_table() {
  static const util::ConfigTable<MoGe2EncoderConfig> table = [] {
    util::ConfigTable<MoGe2EncoderConfig> t;
    t.ignore_unknown_keys();  // as MoGe's DINOv2Encoder(**deprecated_kwargs)
    t.custom(
         "backbone",
         [](const nlohmann::json& json, MoGe2EncoderConfig& config,
            const util::ConfigScope& scope) {
           config.backbone = util::config_json::read_text(json, scope);
           if (custom_backbone(config)) return;
           try {
             config.backbone_config = DinoV2Config::hub(config.backbone);
           } catch (const std::invalid_argument& e) {
             scope.fail(e.what());
           }
         },
         [](const MoGe2EncoderConfig& config, nlohmann::json& json) { json = config.backbone; }, {},
         "a torch.hub DINOv2 name, or dinov2_custom with a backbone_config")
        .required();
    // Read and checked at once: intermediate_layers counts the blocks.
    t.custom(
         "backbone_config",
         [](const nlohmann::json& json, MoGe2EncoderConfig& config,
            const util::ConfigScope& scope) {
           config.backbone_config = dinov2_table().read(json, scope);
           dinov2_table().check(config.backbone_config, scope);
         },
         [](const MoGe2EncoderConfig& config, nlohmann::json& json) {
           dinov2_table().write(config.backbone_config, json);
         },
         [](const MoGe2EncoderConfig& config, const util::ConfigScope& scope) {
           dinov2_table().check(config.backbone_config, scope);
         },
         "DINOv2's constructor keywords")
        .when(custom_backbone, "backbone \"dinov2_custom\"")
        .required("required with backbone \"dinov2_custom\"");
    t.custom(
         "intermediate_layers",
         [list = util::list_codec(util::integer_codec<int64_t>())](const nlohmann::json& json,
                                                                   MoGe2EncoderConfig& config,
                                                                   const util::ConfigScope& scope) {
           const int64_t depth = config.backbone_config.depth;
           if (!json.is_number()) {
             config.intermediate_layers = list.read(json, scope);
             return;
           }
           // MoGe: an int n takes the last n blocks.
           const int64_t count = util::config_json::read_integer(json, 1, depth, scope);
           config.intermediate_layers.clear();
           for (int64_t i = depth - count; i < depth; ++i) config.intermediate_layers.push_back(i);
         },
         [](const MoGe2EncoderConfig& config, nlohmann::json& json) {
           json = config.intermediate_layers;
         },
         [](const MoGe2EncoderConfig& config, const util::ConfigScope& scope) {
           const std::vector<int64_t>& layers = config.intermediate_layers;
           if (layers.empty()) scope.fail("must not be empty");
           for (std::size_t i = 0; i < layers.size(); ++i)
             if (layers[i] < 0 || layers[i] >= config.backbone_config.depth ||
                 (i > 0 && layers[i] <= layers[i - 1]))
               scope.index(i).fail("must be increasing block indices below the depth, " +
                                   std::to_string(config.backbone_config.depth));
         },
         "block indices (an int n: the last n)")
        .required();
    t.field("dim_out", &MoGe2EncoderConfig::dim_out).required().positive();
    return t;
  }();
  return table;
}

util::ConfigCodec<std::vector<int64_t>> scale_head_codec(bool nullable) {
  struct ScaleHead {
    std::vector<int64_t> dims;
  };
  static const util::ConfigTable<ScaleHead> table = [] {
    util::ConfigTable<ScaleHead> t;
    t.field("dims", &ScaleHead::dims, "the MLP's widths, from the ViT's to 1").required();
    return t;
  }();
  util::ConfigCodec<std::vector<int64_t>> codec;
  codec.read = [nullable](const nlohmann::json& json, const util::ConfigScope& scope) {
    if (nullable && json.is_null()) return std::vector<int64_t>();
    return table.read(json, scope).dims;
  };
  codec.write = [nullable](const std::vector<int64_t>& dims, nlohmann::json& json) {
    if (nullable && dims.empty()) return;  // null
    table.write({dims}, json);
  };
  return codec;
}

const util::ConfigTable<MoGe2Config>& moge2_table() {
  static const util::ConfigTable<MoGe2Config> table = [] {
    util::ConfigTable<MoGe2Config> t;
    t.ignore_unknown_keys();  // as MoGe's MoGeModel(**deprecated_kwargs)
    const auto head = util::nullable_codec(util::struct_codec(conv_stack_table()));
    t.field("encoder", &MoGe2Config::encoder, util::struct_codec(moge2_encoder_table())).required();
    t.field("neck", &MoGe2Config::neck, util::struct_codec(conv_stack_table())).required();
    t.field("points_head", &MoGe2Config::points_head, head)
        .check([](const std::optional<ConvStackConfig>& h) { return h.has_value(); }, "required");
    t.field("mask_head", &MoGe2Config::mask_head, head);
    t.field("normal_head", &MoGe2Config::normal_head, head);
    t.field("scale_head", &MoGe2Config::scale_head_dims, scale_head_codec(true),
            "null: no metric scale");
    t.field("remap_output", &MoGe2Config::remap_output)
        .check(
            [](const std::string& remap) {
              return remap == "linear" || remap == "sinh" || remap == "exp" || remap == "sinh_exp";
            },
            "is not one of linear, sinh, exp, sinh_exp");
    t.field("num_tokens_range", &MoGe2Config::num_tokens_range)
        .check([](const std::array<int64_t, 2>& r) { return r[0] > 0 && r[1] >= r[0]; },
               "must be [min, max] with 0 < min <= max");
    t.rule([](const MoGe2Config& config, const util::ConfigScope& scope) {
      if (!config.scale_head_dims.empty())
        check_scale_head(config.scale_head_dims, config.encoder, scope);
      check_neck_inputs(config.encoder, config.neck, scope);
    });
    return t;
  }();
  return table;
}

MoGe2Config MoGe2Config::from_json(const nlohmann::json& json) {
  return util::read_config(moge2_table(), json, "MoGe-2 config");
}

MoGe2Config MoGe2Config::from_json_text(const std::string& text) {
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // parse_error, or out_of_range for 1e999
    throw std::invalid_argument(std::string("MoGe-2 config is not valid JSON: ") + e.what());
  }
  return from_json(json);
}

int64_t MoGe2Config::default_num_tokens(int resolution_level) const {
  const auto [low, high] = num_tokens_range;
  return static_cast<int64_t>(static_cast<double>(low) +
                              resolution_level / 9.0 * static_cast<double>(high - low));
}

TokenGrid token_grid(int64_t height, int64_t width, int64_t num_tokens) {
  if (height <= 0 || width <= 0 || num_tokens <= 0)
    throw std::invalid_argument("token grid: image size and num_tokens must be positive");
  const double aspect = static_cast<double>(width) / static_cast<double>(height);
  // Python's round(): half to even, which nearbyint does in the default rounding mode.
  TokenGrid grid{static_cast<int64_t>(std::nearbyint(std::sqrt(num_tokens / aspect))),
                 static_cast<int64_t>(std::nearbyint(std::sqrt(num_tokens * aspect)))};
  if (grid.rows < 1 || grid.cols < 1)
    throw std::invalid_argument("num_tokens " + std::to_string(num_tokens) +
                                " gives an empty token grid for a " + std::to_string(width) + "x" +
                                std::to_string(height) + " image");
  return grid;
}

at::Tensor remap_points(const at::Tensor& raw, const std::string& remap) {
  if (remap == "linear") return raw;
  if (remap == "sinh") return at::sinh(raw);
  const at::Tensor xy = raw.narrow(-1, 0, 2);
  const at::Tensor z = at::exp(raw.narrow(-1, 2, 1));
  if (remap == "exp") return at::cat({xy * z, z}, -1);
  if (remap == "sinh_exp") return at::cat({at::sinh(xy), z}, -1);
  throw std::invalid_argument("unknown point remap '" + remap + "'");
}

std::vector<at::Tensor> neck_inputs(const at::Tensor& features, const TokenGrid& grid,
                                    double aspect_ratio, int64_t num_levels) {
  const int64_t batch = features.size(0);
  std::vector<at::Tensor> inputs;
  for (int64_t level = 0; level < num_levels; ++level) {
    const at::Tensor uv = geometry::normalized_view_plane_uv(grid.cols << level, grid.rows << level,
                                                             aspect_ratio, features.options())
                              .permute({2, 0, 1})
                              .unsqueeze(0)
                              .expand({batch, 2, grid.rows << level, grid.cols << level});
    inputs.push_back(level == 0 ? at::cat({features, uv}, 1) : uv);
  }
  return inputs;
}

at::Tensor resize_to_image(const at::Tensor& map, const at::Tensor& image) {
  return F::interpolate(map.to(image.scalar_type()),
                        F::InterpolateFuncOptions()
                            .size(std::vector<int64_t>{image.size(2), image.size(3)})
                            .mode(torch::kBilinear)
                            .align_corners(false));
}

at::Tensor resize_to_image_channels_last(const at::Tensor& map, const at::Tensor& image) {
  return resize_to_image(map, image).permute({0, 2, 3, 1}).contiguous();
}

torch::nn::Sequential scale_mlp(const std::vector<int64_t>& dims) {
  torch::nn::Sequential mlp;
  for (size_t i = 0; i + 1 < dims.size(); ++i) {
    if (i > 0) mlp->push_back(torch::nn::ReLU());
    mlp->push_back(Linear(dims[i], dims[i + 1]));
  }
  return mlp;
}

at::Tensor log_metric_scale(torch::nn::Sequential& scale_head, const at::Tensor& class_token,
                            c10::ScalarType dtype) {
  const AutocastOff full_precision;
  return scale_head->forward(class_token.to(dtype)).squeeze(1);
}

// ---------------------------------------------------------------------------------------------
// Encoder

MoGe2EncoderImpl::MoGe2EncoderImpl(const MoGe2EncoderConfig& config) : config_(config) {
  image_mean =
      register_buffer("image_mean", at::tensor({0.485f, 0.456f, 0.406f}).view({1, 3, 1, 1}));
  image_std = register_buffer("image_std", at::tensor({0.229f, 0.224f, 0.225f}).view({1, 3, 1, 1}));
  backbone = register_module("backbone", DinoV2(config_.backbone_config));
  output_projections = register_module("output_projections", torch::nn::ModuleList());
  for (size_t i = 0; i < config_.intermediate_layers.size(); ++i) {
    output_projections->push_back(
        Conv2d(torch::nn::Conv2dOptions(config_.backbone_config.embed_dim, config_.dim_out, 1)));
  }
}

at::Tensor MoGe2EncoderImpl::preprocess(const at::Tensor& image, const TokenGrid& grid) const {
  const int64_t patch = config_.backbone_config.patch_size;
  const at::Tensor resized =
      F::interpolate(image, F::InterpolateFuncOptions()
                                .size(std::vector<int64_t>{grid.rows * patch, grid.cols * patch})
                                .mode(torch::kBilinear)
                                .align_corners(false)
                                .antialias(true));
  return (resized - image_mean) / image_std;
}

EncoderOutput MoGe2EncoderImpl::project(const std::vector<DinoV2Layer>& layers,
                                        const TokenGrid& grid) {
  // A 1×1 convolution of the token grid is a linear map of the token sequence; summing in
  // token layout and transposing once avoids a copy per layer.
  at::Tensor sum;
  for (size_t i = 0; i < layers.size(); ++i) {
    auto& conv = *output_projections->ptr<Conv2dImpl>(i);
    const at::Tensor projected = at::linear(layers[i].patch_tokens, conv.weight.flatten(1),
                                            conv.bias);  // (B, rows·cols, dim_out)
    sum = sum.defined() ? sum + projected : projected;
  }
  const int64_t batch = sum.size(0);
  return {sum.transpose(1, 2).reshape({batch, config_.dim_out, grid.rows, grid.cols}),
          layers.back().class_token};
}

EncoderOutput MoGe2EncoderImpl::forward(const at::Tensor& image, const TokenGrid& grid) {
  return project(backbone->forward(preprocess(image, grid), config_.intermediate_layers), grid);
}

// ---------------------------------------------------------------------------------------------
// Model

MoGe2ModelImpl::MoGe2ModelImpl(const MoGe2Config& config) : config_(config) {
  util::use_default_threads();  // its operators on every core (util/threads.h)
  encoder = register_module("encoder", MoGe2Encoder(config_.encoder));
  neck = register_module("neck", ConvStack(config_.neck));
  points_head = register_module("points_head", ConvStack(*config_.points_head));
  if (config_.mask_head) mask_head = register_module("mask_head", ConvStack(*config_.mask_head));
  if (config_.normal_head)
    normal_head = register_module("normal_head", ConvStack(*config_.normal_head));
  const auto& dims = config_.scale_head_dims;
  if (!dims.empty()) scale_head = register_module("scale_head", scale_mlp(dims));
}

MoGe2RawOutput MoGe2ModelImpl::forward_raw(const at::Tensor& image, const TokenGrid& grid) {
  if (image.dim() != 4 || image.size(1) != 3)
    throw std::invalid_argument("MoGe-2 input must be (B,3,H,W), got " + c10::str(image.sizes()));
  const double aspect = static_cast<double>(image.size(3)) / static_cast<double>(image.size(2));
  const EncoderOutput encoded = encoder->forward(image, grid);
  const std::vector<at::Tensor> neck_levels =
      neck->forward(neck_inputs(encoded.features, grid, aspect, config_.neck.num_levels()));

  MoGe2RawOutput raw;
  raw.projected = encoded.features;
  raw.points = points_head->forward(neck_levels).back();
  if (mask_head) raw.mask = mask_head->forward(neck_levels).back();
  if (normal_head) raw.normal = normal_head->forward(neck_levels).back();
  if (scale_head)
    raw.log_scale = log_metric_scale(scale_head, encoded.class_token, image.scalar_type());
  return raw;
}

MoGe2Output MoGe2ModelImpl::forward(const at::Tensor& image, int64_t num_tokens) {
  if (image.dim() != 4 || image.size(1) != 3)
    throw std::invalid_argument("MoGe-2 input must be (B,3,H,W), got " + c10::str(image.sizes()));
  const MoGe2RawOutput raw =
      forward_raw(image, token_grid(image.size(2), image.size(3), num_tokens));

  // Resize the raw maps first, remap after.
  MoGe2Output output;
  output.points =
      remap_points(resize_to_image_channels_last(raw.points, image), config_.remap_output);
  if (raw.mask.defined()) output.mask = at::sigmoid(resize_to_image(raw.mask, image).squeeze(1));
  if (raw.normal.defined()) {
    const at::Tensor normal = resize_to_image_channels_last(raw.normal, image);
    output.normal = normal / at::linalg_vector_norm(normal, 2, {-1}, true).clamp_min(1e-12);
  }
  if (raw.log_scale.defined()) output.metric_scale = at::exp(raw.log_scale);
  return output;
}

MoGe2Model load_moge2(const std::map<std::string, at::Tensor>& tensors,
                      const std::map<std::string, std::string>& metadata) {
  const auto format = metadata.find("format");
  if (format != metadata.end() && format->second != "moge2")
    throw std::invalid_argument("weights are of format '" + format->second + "', expected 'moge2'");
  const auto config = metadata.find("config");
  if (config == metadata.end())
    throw std::invalid_argument("weights carry no model config (metadata entry 'config')");
  MoGe2Model model = [&] {
    const SkipParameterInit every_parameter_is_loaded;
    return MoGe2Model(MoGe2Config::from_json_text(config->second));
  }();
  load_state_dict(*model, tensors, LoadMode::kStrict, LoadStorage::kShare);
  model->eval();
  return model;
}

}  // namespace omnipoint::model
