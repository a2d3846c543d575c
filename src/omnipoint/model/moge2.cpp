#include "omnipoint/model/moge2.h"

#include <ATen/ATen.h>
#include <torch/nn/functional/upsampling.h>
#include <torch/nn/modules/activation.h>
#include <torch/nn/modules/conv.h>
#include <torch/nn/modules/linear.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <stdexcept>

#include "omnipoint/geometry/view_plane_uv.h"
#include "omnipoint/model/precision.h"
#include "omnipoint/model/state_dict.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::model {

namespace F = torch::nn::functional;

// ---------------------------------------------------------------------------------------------
// Configuration

MoGe2EncoderConfig MoGe2EncoderConfig::from_json(const nlohmann::json& json) {
  if (!json.is_object()) throw std::invalid_argument("MoGe-2 config: 'encoder' must be an object");
  MoGe2EncoderConfig config;
  config.backbone = json.at("backbone").get<std::string>();
  if (config.backbone == "dinov2_custom") {
    if (!json.contains("backbone_config"))
      throw std::invalid_argument(
          "MoGe-2 config: backbone dinov2_custom needs 'encoder.backbone_config'");
    config.backbone_config = DinoV2Config::from_json(json["backbone_config"]);
  } else {
    config.backbone_config = DinoV2Config::hub(config.backbone);
  }
  const int64_t depth = config.backbone_config.depth;
  const nlohmann::json& layers = json.at("intermediate_layers");
  if (layers.is_number_integer()) {  // MoGe: an int n takes the last n blocks
    const int64_t count = layers.get<int64_t>();
    if (count <= 0 || count > depth)
      throw std::invalid_argument("MoGe-2 config: intermediate_layers must be in [1, " +
                                  std::to_string(depth) + "]");
    for (int64_t i = depth - count; i < depth; ++i) config.intermediate_layers.push_back(i);
  } else {
    config.intermediate_layers = layers.get<std::vector<int64_t>>();
  }
  for (size_t i = 0; i < config.intermediate_layers.size(); ++i) {
    const int64_t layer = config.intermediate_layers[i];
    if (layer < 0 || layer >= depth || (i > 0 && layer <= config.intermediate_layers[i - 1]))
      throw std::invalid_argument(
          "MoGe-2 config: intermediate_layers must be increasing block indices below " +
          std::to_string(depth));
  }
  if (config.intermediate_layers.empty())
    throw std::invalid_argument("MoGe-2 config: intermediate_layers is empty");
  config.dim_out = json.at("dim_out").get<int64_t>();
  if (config.dim_out <= 0)
    throw std::invalid_argument("MoGe-2 config: encoder.dim_out must be > 0");
  return config;
}

MoGe2Config MoGe2Config::from_json(const nlohmann::json& json) {
  if (!json.is_object()) throw std::invalid_argument("MoGe-2 config must be a JSON object");
  MoGe2Config config;
  try {
    config.encoder = MoGe2EncoderConfig::from_json(json.at("encoder"));
    config.neck = ConvStackConfig::from_json(json.at("neck"), "MoGe-2 neck");
    for (auto [key, head] :
         {std::pair{"points_head", &config.points_head}, std::pair{"mask_head", &config.mask_head},
          std::pair{"normal_head", &config.normal_head}}) {
      if (json.contains(key) && !json[key].is_null())
        *head = ConvStackConfig::from_json(json[key], std::string("MoGe-2 ") + key);
    }
    if (json.contains("scale_head") && !json["scale_head"].is_null())
      config.scale_head_dims = json["scale_head"].at("dims").get<std::vector<int64_t>>();
    if (json.contains("remap_output"))
      config.remap_output = json["remap_output"].get<std::string>();
    if (json.contains("num_tokens_range")) {
      const auto range = json["num_tokens_range"].get<std::vector<int64_t>>();
      if (range.size() != 2 || range[0] <= 0 || range[1] < range[0])
        throw std::invalid_argument(
            "MoGe-2 config: num_tokens_range must be [min, max] with 0 < min <= max");
      config.num_tokens_range = {range[0], range[1]};
    }
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string("MoGe-2 config: missing or mistyped entry (") +
                                e.what() + ")");
  }
  if (!config.points_head) throw std::invalid_argument("MoGe-2 config: 'points_head' is required");
  if (config.remap_output != "linear" && config.remap_output != "sinh" &&
      config.remap_output != "exp" && config.remap_output != "sinh_exp")
    throw std::invalid_argument("MoGe-2 config: remap_output '" + config.remap_output +
                                "' is not one of linear, sinh, exp, sinh_exp");
  const auto& dims = config.scale_head_dims;
  if (!dims.empty() &&
      (dims.size() < 2 || dims.front() != config.encoder.backbone_config.embed_dim ||
       dims.back() != 1))
    throw std::invalid_argument("MoGe-2 config: scale_head.dims must run from the ViT width to 1");
  const auto& neck_in = config.neck.dim_in[0];
  if (!neck_in || *neck_in != config.encoder.dim_out + 2)
    throw std::invalid_argument(
        "MoGe-2 config: neck.dim_in[0] must be encoder.dim_out + 2 (features and uv)");
  for (int64_t l = 1; l < config.neck.num_levels(); ++l) {
    if (config.neck.dim_in[l] && *config.neck.dim_in[l] != 2)
      throw std::invalid_argument(
          "MoGe-2 config: neck levels above 0 take the 2-channel uv map (dim_in 2)");
  }
  return config;
}

MoGe2Config MoGe2Config::from_json_text(const std::string& text) {
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
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
    mlp->push_back(torch::nn::Linear(dims[i], dims[i + 1]));
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
    output_projections->push_back(torch::nn::Conv2d(
        torch::nn::Conv2dOptions(config_.backbone_config.embed_dim, config_.dim_out, 1)));
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
    auto& conv = *output_projections->ptr<torch::nn::Conv2dImpl>(i);
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
  MoGe2Model model(MoGe2Config::from_json_text(config->second));
  load_state_dict(*model, tensors, LoadMode::kStrict);
  model->eval();
  return model;
}

}  // namespace omnipoint::model
