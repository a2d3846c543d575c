#include "omnipoint/data/synth/benchmark.h"
#include "omnipoint/io/camera_file.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <stdexcept>
#include <string>

namespace omnipoint::data::synth {

constexpr std::uint64_t kSplitSeedStride = 100000;

BenchmarkPlan plan_benchmark(const std::string& json_text, const std::string& what,
                             const std::string& set, int64_t per_split_limit) {
  const auto fail = [&](const std::string& why) {
    throw std::invalid_argument("benchmark " + what + ": " + why);
  };
  nlohmann::json definition;
  try {
    definition = nlohmann::json::parse(json_text);
  } catch (const nlohmann::json::exception& e) {
    fail(std::string("not valid JSON (") + e.what() + ")");
  }
  try {
    BenchmarkPlan plan;
    plan.name = definition.at("name").get<std::string>();
    plan.version = definition.at("version").get<int64_t>();
    if (definition.contains("render")) {
      const auto& render = definition["render"];
      plan.render.shadows = render.value("shadows", plan.render.shadows);
      plan.render.ambient_occlusion =
          render.value("ambient_occlusion", plan.render.ambient_occlusion);
    }
    const auto& sets = definition.at("sets");
    if (!sets.contains(set)) fail("no set \"" + set + "\" (sets: " + sets.dump() + ")");
    const auto base_seed = sets.at(set).get<std::uint64_t>();
    const auto& splits = definition.at("splits");
    if (!splits.is_array() || splits.empty()) fail("\"splits\": expected a non-empty array");
    for (size_t k = 0; k < splits.size(); ++k) {
      const auto& split = splits[k];
      const auto name = split.at("name").get<std::string>();
      const auto count = split.at("count").get<int64_t>();
      std::vector<camera::Camera> cameras;
      for (const auto& spec : split.at("cameras"))
        cameras.push_back(io::read_camera(spec.get<std::string>()));
      std::vector<SceneKind> scenes;
      for (const auto& scene : split.at("scenes"))
        scenes.push_back(parse_scene_kind(scene.get<std::string>()));
      if (name.empty() || name.find('/') != std::string::npos)
        fail("split name \"" + name + "\": expected a folder name");
      if (count < 1 || cameras.empty() || scenes.empty())
        fail("split " + name + ": expected count >= 1 and non-empty \"cameras\" and \"scenes\"");
      if (count > static_cast<int64_t>(kSplitSeedStride))
        fail("split " + name + ": at most " + std::to_string(kSplitSeedStride) +
             " samples (the seed stride between splits)");
      // Folder names of one width per split, so that they sort in sample order.
      const size_t digits = std::max<size_t>(4, std::to_string(count - 1).size());
      const int64_t n = per_split_limit > 0 ? std::min(count, per_split_limit) : count;
      for (int64_t i = 0; i < n; ++i) {
        const std::string index = std::to_string(i);  // never longer than digits
        const std::string folder = "/" + std::string(digits - index.size(), '0') + index;
        const auto c = static_cast<size_t>(i) % cameras.size();
        const auto s = (static_cast<size_t>(i) / cameras.size()) % scenes.size();
        plan.samples.push_back({name + folder, name, cameras[c], scenes[s],
                                base_seed + kSplitSeedStride * k + static_cast<std::uint64_t>(i)});
      }
    }
    return plan;
  } catch (const nlohmann::json::exception& e) {
    fail(std::string("missing or mistyped field (") + e.what() + ")");
  }
  return {};
}

}  // namespace omnipoint::data::synth
