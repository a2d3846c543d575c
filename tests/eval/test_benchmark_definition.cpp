// The committed synthetic benchmark definition meets its specification (docs/EVALUATION.md):
// three splits of at least 200 samples, S.FoV pinhole-type cameras, L.FoV fisheyes of 180–220°,
// full 360° panoramas, indoor and outdoor scenes, and a "final" set sharing no seed with
// "main". Also the planner's rules and errors.
#include <gtest/gtest.h>

#include <map>
#include <set>
#include <stdexcept>
#include <string>

#include "omnipoint/camera/camera_info.h"
#include "omnipoint/data/synth/benchmark.h"
#include "omnipoint/eval/runner.h"
#include "omnipoint/io/atomic_file.h"

namespace omnipoint::data::synth {
namespace {

const std::string kDefinition = std::string(OMNIPOINT_SOURCE_DIR) + "/benchmarks/synthetic_v1.json";

TEST(BenchmarkDefinition, SyntheticV1MeetsItsSpecification) {
  const std::string text = io::read_file(kDefinition);
  std::set<std::uint64_t> main_seeds;
  for (const char* set : {"main", "final"}) {
    const BenchmarkPlan plan = plan_benchmark(text, kDefinition, set);
    EXPECT_EQ(plan.version, 1);
    std::map<std::string, int> per_split;
    std::map<std::string, std::set<SceneKind>> scenes;
    std::set<std::uint64_t> seeds;
    std::set<std::string> checked;
    for (const auto& sample : plan.samples) {
      ++per_split[sample.split];
      scenes[sample.split].insert(sample.scene);
      seeds.insert(sample.seed);
      // Cameras repeat across samples: check each distinct one once.
      if (!checked.insert(sample.split + " " + sample.camera.to_spec()).second) continue;
      const auto split = eval::camera_split(sample.camera);
      const auto fov = camera::field_of_view(sample.camera);
      SCOPED_TRACE(sample.folder + " " + sample.camera.to_spec());
      if (sample.split == "S.FoV") {
        EXPECT_EQ(split, eval::Split::kSmallFov);
        EXPECT_GE(fov.horizontal_deg, 40.0);
        EXPECT_LE(fov.horizontal_deg, 100.0);
      } else if (sample.split == "L.FoV") {
        EXPECT_EQ(split, eval::Split::kLargeFov);
        EXPECT_GE(fov.horizontal_deg, 180.0);
        EXPECT_LE(fov.horizontal_deg, 220.0);
      } else {
        EXPECT_EQ(sample.split, "360");
        EXPECT_EQ(split, eval::Split::kPanorama);
        EXPECT_NEAR(fov.horizontal_deg, 360.0, 1.0);
        EXPECT_EQ(sample.camera.width(), 2 * sample.camera.height());
      }
    }
    EXPECT_EQ(per_split.size(), 3u);
    for (const auto& [split, count] : per_split) {
      EXPECT_GE(count, 200) << split;
      EXPECT_TRUE(scenes[split].count(SceneKind::kIndoor) &&
                  scenes[split].count(SceneKind::kOutdoor))
          << split;
    }
    EXPECT_EQ(seeds.size(), plan.samples.size());
    if (std::string(set) == "main") {
      main_seeds = seeds;
    } else {
      for (const auto seed : seeds) EXPECT_FALSE(main_seeds.count(seed)) << seed;
    }
  }
}

const char* kSmall = R"({"name": "t", "version": 2, "sets": {"main": 5, "final": 9},
  "splits": [{"name": "a", "count": 5, "scenes": ["indoor", "outdoor"],
              "cameras": ["PINHOLE 8 6 6 6 4 3", "EQUIRECTANGULAR 8 4"]},
             {"name": "b", "count": 1, "scenes": ["object"], "cameras": ["PINHOLE 8 6 6 6 4 3"]}]})";

TEST(BenchmarkDefinition, CamerasCycleThenScenesAndSeedsFollowTheSet) {
  const BenchmarkPlan plan = plan_benchmark(kSmall, "small", "final");
  ASSERT_EQ(plan.samples.size(), 6u);
  EXPECT_EQ(plan.samples[0].folder, "a/0000");
  EXPECT_EQ(plan.samples[3].camera.model_name(), "EQUIRECTANGULAR");
  EXPECT_EQ(plan.samples[1].scene, SceneKind::kIndoor);
  EXPECT_EQ(plan.samples[2].scene, SceneKind::kOutdoor);
  EXPECT_EQ(plan.samples[4].scene, SceneKind::kIndoor);
  EXPECT_EQ(plan.samples[4].seed, 9u + 4u);
  EXPECT_EQ(plan.samples[5].folder, "b/0000");
  EXPECT_EQ(plan.samples[5].seed, 9u + 100000u);
  EXPECT_TRUE(plan.render.shadows && plan.render.ambient_occlusion);
  const BenchmarkPlan reduced = plan_benchmark(kSmall, "small", "final", 2);
  ASSERT_EQ(reduced.samples.size(), 3u);
  EXPECT_EQ(reduced.samples[1].seed, plan.samples[1].seed);
}

TEST(BenchmarkDefinition, BadDefinitionsNameTheProblem) {
  const auto message = [](const std::string& text, const std::string& set) {
    try {
      plan_benchmark(text, "def.json", set);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  EXPECT_NE(message("{", "main").find("def.json: not valid JSON"), std::string::npos);
  EXPECT_NE(message(kSmall, "test").find("no set \"test\""), std::string::npos);
  EXPECT_NE(message(R"({"name": "t", "version": 1, "sets": {"main": 1}})", "main")
                .find("missing or mistyped"),
            std::string::npos);
  EXPECT_NE(
      message(
          R"({"name": "t", "version": 1, "sets": {"main": 1}, "splits": [{"name": "a", "count": 0,
                      "scenes": ["indoor"], "cameras": ["PINHOLE 8 6 6 6 4 3"]}]})",
          "main")
          .find("count >= 1"),
      std::string::npos);
  EXPECT_THROW(
      plan_benchmark(R"({"name": "t", "version": 1, "sets": {"main": 1}, "splits": [{"name": "a",
                 "count": 1, "scenes": ["moon"], "cameras": ["PINHOLE 8 6 6 6 4 3"]}]})",
                     "d", "main"),
      std::invalid_argument);
}

}  // namespace
}  // namespace omnipoint::data::synth
