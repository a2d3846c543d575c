#include "omnipoint/model/omnipoint_config.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <iterator>
#include <optional>
#include <stdexcept>

namespace omnipoint::model {
namespace {

// Writers for the MoGe-2 sections, the inverse of their from_json readers.
nlohmann::json optional_dims(const std::vector<std::optional<int64_t>>& dims) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& dim : dims) list.push_back(dim ? nlohmann::json(*dim) : nlohmann::json(nullptr));
  return list;
}

nlohmann::json conv_stack_json(const ConvStackConfig& config) {
  return {{"dim_in", optional_dims(config.dim_in)},
          {"dim_res_blocks", config.dim_res_blocks},
          {"dim_out", optional_dims(config.dim_out)},
          {"num_res_blocks", config.num_res_blocks},
          {"resamplers", config.resamplers},
          {"dim_times_res_block_hidden", config.dim_times_res_block_hidden},
          {"res_block_in_norm", "none"},
          {"res_block_hidden_norm", "none"}};
}

nlohmann::json backbone_json(const DinoV2Config& config) {
  return {{"embed_dim", config.embed_dim},
          {"depth", config.depth},
          {"num_heads", config.num_heads},
          {"mlp_ratio", config.mlp_ratio},
          {"img_size", config.img_size},
          {"patch_size", config.patch_size},
          {"ffn_layer", config.ffn_layer},
          {"init_values", config.init_values},
          {"num_register_tokens", config.num_register_tokens},
          {"interpolate_offset", config.interpolate_offset},
          {"interpolate_antialias", config.interpolate_antialias},
          {"qkv_bias", config.qkv_bias},
          {"proj_bias", config.proj_bias},
          {"ffn_bias", config.ffn_bias},
          {"layer_norm_eps", config.layer_norm_eps},
          {"act", "gelu"},
          {"block_chunks", 0}};
}

nlohmann::json encoder_json(const MoGe2EncoderConfig& config) {
  nlohmann::json json = {{"backbone", config.backbone},
                         {"intermediate_layers", config.intermediate_layers},
                         {"dim_out", config.dim_out}};
  if (config.backbone == "dinov2_custom")
    json["backbone_config"] = backbone_json(config.backbone_config);
  return json;
}

nlohmann::json conditioning_json(const ConditioningConfig& config) {
  return {{"intrinsics", config.intrinsics},
          {"sparse_depth", config.sparse_depth},
          {"state_embeddings", config.state_embeddings},
          {"gaussian_smoothing", config.gaussian_smoothing},
          {"splat_radius", config.splat_radius},
          {"splat_sigma_per_depth", config.splat_sigma_per_depth},
          {"splat_min_sigma", config.splat_min_sigma},
          {"encoder_dim", config.encoder_dim}};
}

ConditioningConfig conditioning_from_json(const nlohmann::json& json) {
  if (!json.is_object())
    throw std::invalid_argument("OmniPoint config: 'conditioning' must be an object");
  ConditioningConfig config;
  for (const auto& [key, value] : json.items()) {
    if (key == "intrinsics")
      config.intrinsics = value.get<bool>();
    else if (key == "sparse_depth")
      config.sparse_depth = value.get<bool>();
    else if (key == "state_embeddings")
      config.state_embeddings = value.get<bool>();
    else if (key == "gaussian_smoothing")
      config.gaussian_smoothing = value.get<bool>();
    else if (key == "splat_radius")
      config.splat_radius = value.get<int64_t>();
    else if (key == "splat_sigma_per_depth")
      config.splat_sigma_per_depth = value.get<double>();
    else if (key == "splat_min_sigma")
      config.splat_min_sigma = value.get<double>();
    else if (key == "encoder_dim")
      config.encoder_dim = value.get<int64_t>();
    else
      throw std::invalid_argument("OmniPoint config: unknown conditioning key '" + key + "'");
  }
  return config;
}

int64_t last_dim_out(const ConvStackConfig& head) {
  return head.dim_out.back().value_or(0);
}

}  // namespace

OmniPointConfig OmniPointConfig::from_json(const nlohmann::json& json) {
  if (!json.is_object()) throw std::invalid_argument("OmniPoint config must be a JSON object");
  static const char* const kKeys[] = {
      "encoder",   "neck",       "ray_head", "distance_head", "points_head",
      "mask_head", "scale_head", "output",   "conditioning",  "num_tokens_range"};
  for (const auto& [key, value] : json.items()) {
    if (std::find(std::begin(kKeys), std::end(kKeys), key) == std::end(kKeys))
      throw std::invalid_argument("OmniPoint config: unknown key '" + key + "'");
  }
  OmniPointConfig config;
  try {
    const std::string output = json.value("output", "ray_distance");
    if (output == "ray_distance")
      config.output = OutputKind::kRayDistance;
    else if (output == "xyz")
      config.output = OutputKind::kXyz;
    else
      throw std::invalid_argument("OmniPoint config: output '" + output +
                                  "' is not ray_distance or xyz");
    config.encoder = MoGe2EncoderConfig::from_json(json.at("encoder"));
    config.neck = ConvStackConfig::from_json(json.at("neck"), "OmniPoint neck");
    if (config.output == OutputKind::kRayDistance) {
      config.ray_head = ConvStackConfig::from_json(json.at("ray_head"), "OmniPoint ray_head");
      config.distance_head =
          ConvStackConfig::from_json(json.at("distance_head"), "OmniPoint distance_head");
    } else {
      config.points_head =
          ConvStackConfig::from_json(json.at("points_head"), "OmniPoint points_head");
    }
    config.mask_head = ConvStackConfig::from_json(json.at("mask_head"), "OmniPoint mask_head");
    config.scale_head_dims = json.at("scale_head").at("dims").get<std::vector<int64_t>>();
    if (json.contains("conditioning"))
      config.conditioning = conditioning_from_json(json["conditioning"]);
    if (json.contains("num_tokens_range")) {
      const auto range = json["num_tokens_range"].get<std::vector<int64_t>>();
      if (range.size() != 2)
        throw std::invalid_argument("OmniPoint config: num_tokens_range must be [min, max]");
      config.num_tokens_range = {range[0], range[1]};
    }
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(std::string("OmniPoint config: missing or mistyped entry (") +
                                e.what() + ")");
  }
  config.validate();
  return config;
}

OmniPointConfig OmniPointConfig::from_json_text(const std::string& text) {
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw std::invalid_argument(std::string("OmniPoint config is not valid JSON: ") + e.what());
  }
  return from_json(json);
}

nlohmann::json OmniPointConfig::to_json() const {
  nlohmann::json json = {{"encoder", encoder_json(encoder)},
                         {"neck", conv_stack_json(neck)},
                         {"mask_head", conv_stack_json(mask_head)},
                         {"scale_head", {{"dims", scale_head_dims}}},
                         {"conditioning", conditioning_json(conditioning)},
                         {"num_tokens_range", num_tokens_range}};
  if (output == OutputKind::kRayDistance) {
    json["output"] = "ray_distance";
    json["ray_head"] = conv_stack_json(ray_head);
    json["distance_head"] = conv_stack_json(distance_head);
  } else {
    json["output"] = "xyz";
    json["points_head"] = conv_stack_json(points_head);
  }
  return json;
}

std::string OmniPointConfig::to_json_text() const {
  return to_json().dump();
}

void OmniPointConfig::validate() const {
  const auto fail = [](const std::string& what) {
    throw std::invalid_argument("OmniPoint config: " + what);
  };
  if (!neck.dim_in[0] || *neck.dim_in[0] != encoder.dim_out + 2)
    fail("neck.dim_in[0] must be encoder.dim_out + 2 (features and uv)");
  for (int64_t level = 1; level < neck.num_levels(); ++level) {
    if (neck.dim_in[level] && *neck.dim_in[level] != 2)
      fail("neck levels above 0 take the uv map (dim_in 2)");
  }
  const auto check_head = [&](const ConvStackConfig& head, const std::string& name,
                              int64_t channels) {
    if (head.num_levels() != neck.num_levels())
      fail(name + " must have as many levels as the neck");
    if (last_dim_out(head) != channels)
      fail(name + " must output " + std::to_string(channels) + " channel(s)");
    for (int64_t level = 0; level < head.num_levels(); ++level) {
      const int64_t neck_out = neck.dim_out[level].value_or(neck.dim_res_blocks[level]);
      if (head.dim_in[level] && *head.dim_in[level] != neck_out)
        fail(name + ".dim_in[" + std::to_string(level) + "] must equal the neck's output channels");
    }
  };
  if (output == OutputKind::kRayDistance) {
    check_head(ray_head, "ray_head", 3);
    check_head(distance_head, "distance_head", 1);
  } else {
    check_head(points_head, "points_head", 3);
  }
  check_head(mask_head, "mask_head", 1);
  const auto& dims = scale_head_dims;
  if (dims.size() < 2 || dims.front() != encoder.backbone_config.embed_dim || dims.back() != 1)
    fail("scale_head.dims must run from the ViT width to 1");
  if (conditioning.encoder_dim <= 0) fail("conditioning.encoder_dim must be > 0");
  if (conditioning.splat_radius < 0) fail("conditioning.splat_radius must be >= 0");
  if (!(conditioning.splat_sigma_per_depth > 0) || !(conditioning.splat_min_sigma > 0))
    fail("conditioning splat sigmas must be > 0");
  if (num_tokens_range[0] <= 0 || num_tokens_range[1] < num_tokens_range[0])
    fail("num_tokens_range must be [min, max] with 0 < min <= max");
}

OmniPointConfig OmniPointConfig::from_moge2(const MoGe2Config& moge2, OutputKind output,
                                            const ConditioningConfig& conditioning) {
  if (!moge2.mask_head || moge2.scale_head_dims.empty())
    throw std::invalid_argument(
        "MoGe-2 config: an OmniPoint model needs its mask_head and scale_head");
  if (moge2.remap_output != "exp")
    throw std::invalid_argument(
        "MoGe-2 config: OmniPoint heads follow remap_output \"exp\", got \"" + moge2.remap_output +
        "\"");
  OmniPointConfig config;
  config.encoder = moge2.encoder;
  config.neck = moge2.neck;
  config.mask_head = *moge2.mask_head;
  config.scale_head_dims = moge2.scale_head_dims;
  config.num_tokens_range = moge2.num_tokens_range;
  config.conditioning = conditioning;
  config.output = output;
  if (output == OutputKind::kRayDistance) {
    config.ray_head = *moge2.points_head;
    config.distance_head = *moge2.points_head;
    config.distance_head.dim_out.back() = 1;
  } else {
    config.points_head = *moge2.points_head;
  }
  config.validate();
  return config;
}

std::map<std::string, std::string> omnipoint_metadata(const OmniPointConfig& config) {
  return {{"format", "omnipoint"}, {"config", config.to_json_text()}};
}

OmniPointConfig config_from_metadata(const std::map<std::string, std::string>& metadata) {
  const auto format = metadata.find("format");
  if (format == metadata.end() || format->second != "omnipoint")
    throw std::invalid_argument("weights metadata: expected \"format\": \"omnipoint\"");
  const auto config = metadata.find("config");
  if (config == metadata.end())
    throw std::invalid_argument("weights metadata: no \"config\" entry");
  return OmniPointConfig::from_json_text(config->second);
}

}  // namespace omnipoint::model
