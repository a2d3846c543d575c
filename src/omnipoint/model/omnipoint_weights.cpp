#include "omnipoint/model/omnipoint_weights.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <set>
#include <sstream>
#include <stdexcept>

#include "omnipoint/model/layers.h"
#include "omnipoint/model/state_dict.h"

namespace omnipoint::model {
namespace {

using TensorMap = std::map<std::string, at::Tensor>;

bool starts_with(const std::string& text, const std::string& prefix) {
  return text.compare(0, prefix.size(), prefix) == 0;
}

bool under_any(const std::string& name, const std::vector<std::string>& prefixes) {
  return std::any_of(prefixes.begin(), prefixes.end(),
                     [&](const std::string& p) { return starts_with(name, p); });
}

// Every model tensor under `prefixes` must be in `source` with its shape; one
// std::runtime_error listing the problems otherwise.
void require_all(const TensorMap& model, const TensorMap& source,
                 const std::vector<std::string>& prefixes, const std::string& checkpoint) {
  std::vector<std::string> problems;
  for (const auto& [name, tensor] : model) {
    if (!under_any(name, prefixes)) continue;
    const auto found = source.find(name);
    if (found == source.end()) {
      problems.push_back(name + " missing");
    } else if (found->second.sizes() != tensor.sizes()) {
      std::ostringstream what;
      what << name << " has shape " << found->second.sizes() << ", the model " << tensor.sizes();
      problems.push_back(what.str());
    }
  }
  if (problems.empty()) return;
  std::ostringstream message;
  message << checkpoint << " does not fit the OmniPoint model (" << problems.size()
          << " problems: ";
  for (std::size_t i = 0; i < problems.size() && i < 10; ++i)
    message << (i ? "; " : "") << problems[i];
  if (problems.size() > 10) message << "; ... and " << problems.size() - 10 << " more";
  message << ')';
  throw std::runtime_error(message.str());
}

// Loads `source` (model names) partially and sorts the outcome into the report.
InitReport load_and_report(OmniPointModelImpl& model, const TensorMap& source,
                           std::set<std::string> ignored,
                           const std::map<std::string, std::string>& derived_from) {
  const LoadReport loaded = load_state_dict(model, source, LoadMode::kPartial);
  InitReport report;
  for (const std::string& name : loaded.loaded) {
    const auto how = derived_from.find(name);
    if (how == derived_from.end())
      report.loaded.push_back(name);
    else
      report.derived.push_back(name + " <- " + how->second);
  }
  report.kept = loaded.missing;
  for (const std::string& name : loaded.mismatched) {
    report.kept.push_back(name);
    ignored.insert(name);
  }
  for (const std::string& name : loaded.unexpected) ignored.insert(name);
  std::sort(report.kept.begin(), report.kept.end());
  report.ignored.assign(ignored.begin(), ignored.end());
  return report;
}

void append_group(std::ostringstream& out, const char* title,
                  const std::vector<std::string>& names) {
  out << title << ' ' << names.size();
  for (std::size_t i = 0; i < names.size(); ++i) out << (i ? ", " : ": ") << names[i];
  out << '\n';
}

}  // namespace

std::string InitReport::summary() const {
  std::ostringstream out;
  append_group(out, "loaded", loaded);
  append_group(out, "derived", derived);
  append_group(out, "kept", kept);
  append_group(out, "ignored", ignored);
  return out.str();
}

InitReport init_from_moge2(OmniPointModelImpl& model, const TensorMap& moge2,
                           const MoGe2Config& moge2_config) {
  const OmniPointConfig& config = model.config();
  if (moge2_config.remap_output != "exp")
    throw std::invalid_argument("MoGe-2 initialisation needs remap_output \"exp\", got \"" +
                                moge2_config.remap_output + "\"");
  const std::vector<std::string> shared = {"encoder.", "neck.", "mask_head.", "scale_head."};
  // The points head's output conv: the last level's output block.
  const std::string output_conv =
      "output_blocks." + std::to_string(moge2_config.points_head->num_levels() - 1) + ".";

  TensorMap source;
  std::set<std::string> ignored;
  std::map<std::string, std::string> derived_from;
  for (const auto& [name, tensor] : moge2) {
    if (under_any(name, shared)) {
      source[name] = tensor;
    } else if (starts_with(name, "points_head.")) {
      const std::string suffix = name.substr(std::string("points_head.").size());
      if (config.output == OutputKind::kXyz) {
        source[name] = tensor;
      } else if (!starts_with(suffix, output_conv)) {
        source["ray_head." + suffix] = tensor;
        source["distance_head." + suffix] = tensor;
      } else {
        // Ray channels (a, b, 1): x and y rows as they are, the third a constant 1.
        at::Tensor ray = tensor.clone();
        ray[2].zero_();
        if (suffix == output_conv + "bias") ray[2].fill_(1.0);
        source["ray_head." + suffix] = ray;
        derived_from["ray_head." + suffix] = name + ": rows x, y; row 3 = constant 1";
        source["distance_head." + suffix] = tensor.narrow(0, 2, 1).clone();
        derived_from["distance_head." + suffix] = name + ": row z (log distance = MoGe-2's log z)";
      }
    } else {
      ignored.insert(name);
    }
  }
  require_all(state_dict(model), source, shared, "MoGe-2 checkpoint");
  return load_and_report(model, source, std::move(ignored), derived_from);
}

InitReport init_from_dinov2(OmniPointModelImpl& model, const TensorMap& dinov2) {
  const std::string prefix = "encoder.backbone.", moge1_prefix = "backbone.";
  TensorMap source;
  for (const auto& [name, tensor] : dinov2) {
    if (starts_with(name, prefix))
      source[name] = tensor;
    else if (starts_with(name, moge1_prefix))  // MoGe-1's model: its backbone is a DINOv2
      source[prefix + name.substr(moge1_prefix.size())] = tensor;
    else
      source[prefix + name] = tensor;
  }
  require_all(state_dict(model), source, {prefix}, "DINOv2 checkpoint");
  return load_and_report(model, source, {}, {});
}

OmniPointModel load_omnipoint_model(const TensorMap& tensors,
                                    const std::map<std::string, std::string>& metadata) {
  OmniPointModel model = [&] {
    const SkipParameterInit every_parameter_is_loaded;
    return OmniPointModel(config_from_metadata(metadata));
  }();
  load_state_dict(*model, tensors, LoadMode::kStrict, LoadStorage::kShare);
  return model;
}

}  // namespace omnipoint::model
