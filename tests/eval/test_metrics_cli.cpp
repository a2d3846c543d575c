// End to end: `omnipoint metrics` on the fixture's files reproduces MoGe's expected metrics,
// and bad inputs give one clear line and a non-zero exit.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>

#include "support/cli_run.h"

namespace fs = std::filesystem;

namespace {

const std::string kFixture = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge_metrics_a";

using omnipoint::test::CliRun;
using omnipoint::test::slurp;

CliRun run_cli(const std::string& args) {
  const fs::path dir =
      fs::temp_directory_path() / ("omnipoint_metrics_cli_" + std::to_string(::getpid()));
  CliRun run = omnipoint::test::run_omnipoint("metrics " + args, dir);
  fs::remove_all(dir);
  return run;
}

std::string instance_args(int k) {
  const std::string d = kFixture + "/instance_" + std::to_string(k) + "/";
  return "--gt-depth " + d + "gt_depth.npy --pred-depth " + d + "pred_depth.npy --gt-points " + d +
         "gt_points.npy --pred-points " + d + "pred_points.npy --mask " + d + "mask.npy";
}

class MetricsCli : public ::testing::TestWithParam<int> {};

TEST_P(MetricsCli, MatchesExpectedJson) {
  const int k = GetParam();
  const auto expected =
      nlohmann::json::parse(slurp(kFixture + "/instance_" + std::to_string(k) + "/expected.json"));
  const bool metric = expected["is_metric"].get<bool>();
  const CliRun run = run_cli(instance_args(k) + (metric ? " --metric" : ""));
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.err, "");
  const auto got = nlohmann::json::parse(run.out);
  ASSERT_EQ(got.size(), expected["metrics"].size());
  const double num_valid = expected["num_valid_pixels"].get<double>();
  for (const auto& [name, value] : expected["metrics"].items()) {
    SCOPED_TRACE(name);
    ASSERT_TRUE(got.contains(name));
    const double rel = value["rel"].get<double>();
    EXPECT_NEAR(got[name]["rel"].get<double>(), rel, 1e-5 * rel);
    EXPECT_LE(std::abs(got[name]["delta1"].get<double>() - value["delta1"].get<double>()),
              2.0 / num_valid);
  }
}

INSTANTIATE_TEST_SUITE_P(Instances, MetricsCli, ::testing::Values(0, 1, 2, 3));

void expect_clear_failure(const std::string& args, const std::string& fragment) {
  const CliRun run = run_cli(args);
  EXPECT_NE(run.status, 0);
  EXPECT_EQ(run.out, "");
  EXPECT_NE(run.err.find(fragment), std::string::npos) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
}

const std::string kInstance0 = kFixture + "/instance_0/";

TEST(MetricsCliErrors, MissingFile) {
  const std::string& d = kInstance0;
  expect_clear_failure("--gt-depth " + d + "missing.npy --pred-depth " + d + "pred_depth.npy",
                       "missing.npy");
}

TEST(MetricsCliErrors, WrongShapes) {
  const std::string& d = kInstance0;
  expect_clear_failure("--gt-depth " + d + "gt_depth.npy --pred-depth " + d + "pred_points.npy",
                       "expected shape (H, W)");
  expect_clear_failure(
      "--gt-depth " + d + "gt_depth.npy --pred-depth " + kFixture + "/instance_1/pred_depth.npy",
      "does not match --gt-depth");
}

TEST(MetricsCliErrors, WrongDtypes) {
  const std::string& d = kInstance0;
  expect_clear_failure("--gt-depth " + d + "gt_depth.npy --pred-depth " + d +
                           "pred_depth.npy --mask " + d + "lr_index.npy",
                       "uint8 or bool");
  expect_clear_failure("--gt-depth " + d + "mask.npy --pred-depth " + d + "pred_depth.npy",
                       "float32 or float64");
}

TEST(MetricsCliErrors, PointsComeInPairs) {
  const std::string& d = kInstance0;
  expect_clear_failure("--gt-depth " + d + "gt_depth.npy --pred-depth " + d +
                           "pred_depth.npy --gt-points " + d + "gt_points.npy",
                       "together");
}

TEST(MetricsCliErrors, DefaultMaskExcludesInvalidDepth) {
  // Without --mask, GT depth 0/inf marks invalid pixels: the depth entries equal the masked run.
  const std::string& d = kInstance0;
  const CliRun with_mask = run_cli("--gt-depth " + d + "gt_depth.npy --pred-depth " + d +
                                   "pred_depth.npy --mask " + d + "mask.npy");
  const CliRun without =
      run_cli("--gt-depth " + d + "gt_depth.npy --pred-depth " + d + "pred_depth.npy");
  ASSERT_EQ(without.status, 0) << without.err;
  EXPECT_EQ(nlohmann::json::parse(with_mask.out), nlohmann::json::parse(without.out));
}

}  // namespace
