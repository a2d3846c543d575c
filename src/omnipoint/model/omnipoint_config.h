#pragma once
// The configuration of an OmniPoint network, stored as JSON in the safetensors metadata:
// {"format": "omnipoint", "config": "<JSON>"}. The sections shared with MoGe-2 keep MoGe-2's
// keys and meaning (fixtures README §0.1), so a MoGe-2 config converts section by section:
//   "encoder"        MoGe-2's encoder: backbone (hub name or "dinov2_custom" + backbone_config),
//                    intermediate_layers, dim_out
//   "neck"           ConvStack, level 0 takes dim_out + 2 (features, uv), levels ≥ 1 take uv
//   "ray_head"       ConvStack with dim_out 3 at the last level     } output "ray_distance"
//   "distance_head"  ConvStack with dim_out 1 at the last level     }
//   "points_head"    ConvStack with dim_out 3 (MoGe's exp remap)    } output "xyz" (ablation)
//   "mask_head"      ConvStack with dim_out 1
//   "scale_head"     {"dims": [embed_dim, ..., 1]}
//   "output"         "ray_distance" (default) | "xyz"
//   "conditioning"   the keys of ConditioningConfig (all optional, defaults below)
#include <nlohmann/json_fwd.hpp>

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "omnipoint/model/conditioning.h"
#include "omnipoint/model/conv_stack.h"
#include "omnipoint/model/moge2.h"

namespace omnipoint::model {

enum class OutputKind { kRayDistance, kXyz };
// "ray_distance" | "xyz", the config's names.
const std::vector<std::pair<std::string, OutputKind>>& output_kind_names();

struct OmniPointConfig {
  MoGe2EncoderConfig encoder;
  ConvStackConfig neck;
  ConvStackConfig ray_head;       // kRayDistance only
  ConvStackConfig distance_head;  // kRayDistance only
  ConvStackConfig points_head;    // kXyz only
  ConvStackConfig mask_head;
  std::vector<int64_t> scale_head_dims;
  ConditioningConfig conditioning;
  OutputKind output = OutputKind::kRayDistance;
  std::array<int64_t, 2> num_tokens_range{1200, 3600};  // as MoGe-2's, for default resolutions

  // Read and written through omnipoint_table() (model/config_tables.h). Bad JSON, unknown or
  // mistyped keys and inconsistent shapes throw std::invalid_argument, one line naming the key
  // ("OmniPoint config: neck.dim_in[0]: must be encoder.dim_out + 2 (features and uv)").
  static OmniPointConfig from_json(const nlohmann::json& json);
  static OmniPointConfig from_json_text(const std::string& text);
  nlohmann::json to_json() const;
  std::string to_json_text() const;
  void validate() const;  // the table's checks

  // The OmniPoint counterpart of a MoGe-2 model: its encoder, neck, mask and scale heads, and
  // ray/distance (or points) heads shaped like its points head.
  static OmniPointConfig from_moge2(const MoGe2Config& moge2, OutputKind output,
                                    const ConditioningConfig& conditioning = {});
};

// The safetensors metadata of an OmniPoint checkpoint, and back (std::invalid_argument when
// "format" is not "omnipoint" or the config is bad).
std::map<std::string, std::string> omnipoint_metadata(const OmniPointConfig& config);
OmniPointConfig config_from_metadata(const std::map<std::string, std::string>& metadata);

}  // namespace omnipoint::model
