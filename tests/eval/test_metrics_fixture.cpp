// Parity with MoGe's compute_metrics on tests/fixtures/moge_metrics_a (its README §2).
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>

#include "omnipoint/eval/metrics.h"
#include "omnipoint/io/npy.h"

using omnipoint::eval::compute_metrics;
using omnipoint::io::read_npy;

namespace {

const std::string kFixture = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge_metrics_a";

nlohmann::json read_json(const std::string& path) {
  std::ifstream file(path);
  return nlohmann::json::parse(file);
}

// NOLINTNEXTLINE(bugprone-exception-escape): the implicit moves are those of its members.
struct Instance {
  omnipoint::eval::GroundTruth gt;
  omnipoint::eval::Prediction pred;
  nlohmann::json expected;
  std::string dir;
};

Instance load_instance(int k) {
  Instance in;
  in.dir = kFixture + "/instance_" + std::to_string(k);
  in.expected = read_json(in.dir + "/expected.json");
  in.gt.depth = read_npy(in.dir + "/gt_depth.npy");
  in.gt.points = read_npy(in.dir + "/gt_points.npy");
  in.gt.mask = read_npy(in.dir + "/mask.npy").to(at::kBool);
  in.gt.is_metric = in.expected["is_metric"].get<bool>();
  in.pred.depth = read_npy(in.dir + "/pred_depth.npy");
  in.pred.points = read_npy(in.dir + "/pred_points.npy");
  in.pred.is_metric = true;  // MoGe-2's evaluation wrapper passes metric predictions
  return in;
}

// compute_metrics once per instance; several tests read the result.
const omnipoint::eval::Metrics& metrics_of(int k) {
  static std::map<int, omnipoint::eval::Metrics> cache;
  auto it = cache.find(k);
  if (it == cache.end()) {
    const Instance in = load_instance(k);
    it = cache.emplace(k, compute_metrics(in.pred, in.gt)).first;
  }
  return it->second;
}

class MetricsFixture : public ::testing::TestWithParam<int> {};

TEST_P(MetricsFixture, SubsampleIsBitExact) {
  const Instance in = load_instance(GetParam());
  const auto sub = omnipoint::eval::mask_aware_subsample(in.gt.mask);
  const at::Tensor lr_mask = read_npy(in.dir + "/lr_mask.npy").to(at::kBool);
  const at::Tensor lr_index = read_npy(in.dir + "/lr_index.npy").to(at::kLong);
  ASSERT_TRUE(at::equal(sub.mask, lr_mask));
  EXPECT_TRUE(at::equal(sub.index.index({at::indexing::Slice(), lr_mask}),
                        lr_index.index({at::indexing::Slice(), lr_mask})));
  EXPECT_EQ(lr_mask.sum().item<int64_t>(), in.expected["num_lowres_samples"].get<int64_t>());
}

TEST_P(MetricsFixture, EntriesMatchMoGe) {
  const Instance in = load_instance(GetParam());
  const auto& metrics = metrics_of(GetParam());
  EXPECT_TRUE(metrics.warnings.empty());
  const double num_valid = in.expected["num_valid_pixels"].get<double>();
  EXPECT_EQ(metrics.num_valid_pixels, in.expected["num_valid_pixels"].get<int64_t>());
  ASSERT_EQ(metrics.entries.size(), in.expected["metrics"].size());
  for (const auto& [name, value] : in.expected["metrics"].items()) {
    SCOPED_TRACE(name);
    ASSERT_EQ(metrics.entries.count(name), 1u);
    const auto& got = metrics.entries.at(name);
    const double rel = value["rel"].get<double>();
    EXPECT_NEAR(got.rel, rel, 1e-5 * std::abs(rel));
    EXPECT_LE(std::abs(got.delta1 - value["delta1"].get<double>()), 2.0 / num_valid);
  }
}

TEST_P(MetricsFixture, AlignmentsMatchMoGe) {
  const Instance in = load_instance(GetParam());
  const auto& metrics = metrics_of(GetParam());
  for (const auto& [name, value] : in.expected["alignment"].items()) {
    SCOPED_TRACE(name);
    const auto& got = metrics.alignment.at(name);
    auto near = [](double a, double b) {
      return std::abs(a - b) <= 1e-4 * std::max(std::abs(b), 1e-3);
    };
    if (value.contains("scale")) {
      EXPECT_PRED2(near, got.scale, value["scale"].get<double>());
    }
    if (value.contains("clamp_min_disparity")) {
      EXPECT_PRED2(near, got.clamp_min_disparity, value["clamp_min_disparity"].get<double>());
    }
    if (value.contains("shift")) {
      const auto& shift = value["shift"];
      if (shift.is_array()) {
        ASSERT_EQ(got.shift.size(), shift.size());
        for (size_t c = 0; c < shift.size(); ++c)
          EXPECT_PRED2(near, got.shift[c], shift[c].get<double>());
      } else {
        ASSERT_EQ(got.shift.size(), 1u);
        EXPECT_PRED2(near, got.shift[0], shift.get<double>());
      }
    }
  }
}

INSTANTIATE_TEST_SUITE_P(Instances, MetricsFixture, ::testing::Values(0, 1, 2, 3));

TEST(MetricsFixtureMean, FolderAverageMatchesKeyAverage) {
  std::vector<omnipoint::eval::Metrics> all;
  for (int k = 0; k < 4; ++k) all.push_back(metrics_of(k));
  const auto mean = omnipoint::eval::average_metrics(all);
  const auto expected = read_json(kFixture + "/expected.json")["mean_over_instances_key_average"];
  ASSERT_EQ(mean.size(), expected.size());
  for (const auto& [name, value] : expected.items()) {
    SCOPED_TRACE(name);
    const double rel = value["rel"].get<double>();
    EXPECT_NEAR(mean.at(name).rel, rel, 1e-5 * rel);
    EXPECT_NEAR(mean.at(name).delta1, value["delta1"].get<double>(), 2.0 / 4932);
    EXPECT_EQ(mean.at(name).excluded, 0);
  }
}

}  // namespace
