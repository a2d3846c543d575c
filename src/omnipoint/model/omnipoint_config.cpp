#include "omnipoint/model/omnipoint_config.h"

#include <nlohmann/json.hpp>

#include <stdexcept>

#include "omnipoint/model/config_tables.h"

namespace omnipoint::model {

const std::vector<std::pair<std::string, OutputKind>>& output_kind_names() {
  static const std::vector<std::pair<std::string, OutputKind>> names = {
      {"ray_distance", OutputKind::kRayDistance}, {"xyz", OutputKind::kXyz}};
  return names;
}

const util::ConfigTable<ConditioningConfig>& conditioning_table() {
  static const util::ConfigTable<ConditioningConfig> table = [] {
    util::ConfigTable<ConditioningConfig> t;
    t.field("intrinsics", &ConditioningConfig::intrinsics);
    t.field("sparse_depth", &ConditioningConfig::sparse_depth);
    t.field("state_embeddings", &ConditioningConfig::state_embeddings);
    t.field("gaussian_smoothing", &ConditioningConfig::gaussian_smoothing);
    t.field("splat_radius", &ConditioningConfig::splat_radius).at_least(0);
    t.field("splat_sigma_per_depth", &ConditioningConfig::splat_sigma_per_depth).positive();
    t.field("splat_min_sigma", &ConditioningConfig::splat_min_sigma).positive();
    t.field("encoder_dim", &ConditioningConfig::encoder_dim).positive();
    return t;
  }();
  return table;
}

namespace {

bool ray_distance(const OmniPointConfig& config) {
  return config.output == OutputKind::kRayDistance;
}
bool xyz(const OmniPointConfig& config) {
  return config.output == OutputKind::kXyz;
}

// A head on the neck's levels ending in `channels` channels.
void check_head(const OmniPointConfig& config, const ConvStackConfig& head, const char* name,
                int64_t channels, const util::ConfigScope& scope) {
  const ConvStackConfig& neck = config.neck;
  const util::ConfigScope at = scope.key(name);
  if (head.num_levels() != neck.num_levels())
    at.key("dim_res_blocks").fail("must have as many levels as the neck's");
  if (head.dim_out.back().value_or(0) != channels)
    at.key("dim_out")
        .index(head.dim_out.size() - 1)
        .fail("must be " + std::to_string(channels) + " (the head's output channels)");
  for (std::size_t level = 0; level < head.dim_in.size(); ++level) {
    const int64_t neck_out = neck.dim_out[level].value_or(neck.dim_res_blocks[level]);
    if (head.dim_in[level] && *head.dim_in[level] != neck_out)
      at.key("dim_in").index(level).fail("must equal the neck's output channels (" +
                                         std::to_string(neck_out) + ")");
  }
}

}  // namespace

const util::ConfigTable<OmniPointConfig>& omnipoint_table() {
  static const util::ConfigTable<OmniPointConfig> table = [] {
    util::ConfigTable<OmniPointConfig> t;
    const auto stack = util::struct_codec(conv_stack_table());
    // First: which heads apply.
    t.field("output", &OmniPointConfig::output, util::enum_codec(output_kind_names()));
    t.field("encoder", &OmniPointConfig::encoder, util::struct_codec(moge2_encoder_table()))
        .required();
    t.field("neck", &OmniPointConfig::neck, stack).required();
    t.field("ray_head", &OmniPointConfig::ray_head, stack)
        .when(ray_distance, "\"output\": \"ray_distance\"")
        .required();
    t.field("distance_head", &OmniPointConfig::distance_head, stack)
        .when(ray_distance, "\"output\": \"ray_distance\"")
        .required();
    t.field("points_head", &OmniPointConfig::points_head, stack)
        .when(xyz, "\"output\": \"xyz\"")
        .required();
    t.field("mask_head", &OmniPointConfig::mask_head, stack).required();
    t.field("scale_head", &OmniPointConfig::scale_head_dims, scale_head_codec(false)).required();
    t.field("conditioning", &OmniPointConfig::conditioning,
            util::struct_codec(conditioning_table()));
    t.field("num_tokens_range", &OmniPointConfig::num_tokens_range)
        .check([](const std::array<int64_t, 2>& r) { return r[0] > 0 && r[1] >= r[0]; },
               "must be [min, max] with 0 < min <= max");
    t.rule([](const OmniPointConfig& config, const util::ConfigScope& scope) {
      check_neck_inputs(config.encoder, config.neck, scope);
      if (config.output == OutputKind::kRayDistance) {
        check_head(config, config.ray_head, "ray_head", 3, scope);
        check_head(config, config.distance_head, "distance_head", 1, scope);
      } else {
        check_head(config, config.points_head, "points_head", 3, scope);
      }
      check_head(config, config.mask_head, "mask_head", 1, scope);
      check_scale_head(config.scale_head_dims, config.encoder, scope);
    });
    return t;
  }();
  return table;
}

namespace {
const char* const kDocument = "OmniPoint config";
}  // namespace

OmniPointConfig OmniPointConfig::from_json(const nlohmann::json& json) {
  return util::read_config(omnipoint_table(), json, kDocument);
}

OmniPointConfig OmniPointConfig::from_json_text(const std::string& text) {
  nlohmann::json json;
  try {
    json = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {  // parse_error, or out_of_range for 1e999
    throw std::invalid_argument(std::string("OmniPoint config is not valid JSON: ") + e.what());
  }
  return from_json(json);
}

nlohmann::json OmniPointConfig::to_json() const {
  nlohmann::json json;
  omnipoint_table().write(*this, json);
  return json;
}

std::string OmniPointConfig::to_json_text() const {
  return to_json().dump();
}

void OmniPointConfig::validate() const {
  util::check_config(omnipoint_table(), *this, kDocument);
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
