// The benchmark runner on closed-form cases: the oracle scores Rel 0 / δ1 1 on every split and
// mode, a constant-distance baseline scores worse, the summary and the table have the right
// rows and columns, sparse-depth sampling is deterministic, bad samples are skipped and counted.
#include <gtest/gtest.h>

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "eval/eval_test_data.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset_index.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/eval/predictors.h"
#include "omnipoint/eval/runner.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/model/omnipoint_config.h"

namespace omnipoint::eval {
namespace {
namespace fs = std::filesystem;

const std::vector<std::string> kModes{"none", "+K", "+D", "+K+D"};

RunOptions all_modes(int64_t sparse_points = 50) {
  RunOptions options;
  options.modes = evaluation_modes(true, true);
  options.sparse_depth_points = sparse_points;
  return options;
}

class RunnerTest : public ::testing::Test {
 protected:
  // The oracle's run in every mode, shared by the tests that read it (metrics take time).
  static void SetUpTestSuite() {
    root_ = new fs::path(testing::make_tiny_dataset("runner"));
    oracle_ = new RunResult(run_benchmark(oracle_predictor(), {root_->string()}, all_modes()));
  }
  static void TearDownTestSuite() {
    fs::remove_all(*root_);
    delete root_;
    delete oracle_;
  }
  static fs::path* root_;
  static RunResult* oracle_;
};
fs::path* RunnerTest::root_ = nullptr;
RunResult* RunnerTest::oracle_ = nullptr;

TEST(RunnerSplits, FollowTheCameraModel) {
  EXPECT_EQ(camera_split(camera::parse_camera("PINHOLE 32 24 24 24 16 12")), Split::kSmallFov);
  EXPECT_EQ(camera_split(camera::parse_camera("OPENCV 32 24 24 24 16 12 -0.1 0.01 0 0")),
            Split::kSmallFov);
  EXPECT_EQ(camera_split(camera::parse_camera("OPENCV_FISHEYE 32 32 10 10 16 16 0 0 0 0")),
            Split::kLargeFov);
  EXPECT_EQ(camera_split(camera::parse_camera("DOUBLE_SPHERE 32 32 10 10 16 16 -0.2 0.6")),
            Split::kLargeFov);
  EXPECT_EQ(camera_split(camera::parse_camera("EQUIRECTANGULAR 32 16")), Split::kPanorama);
  EXPECT_EQ(split_name(Split::kPanorama), "360°");
}

TEST(RunnerModes, NoneFirstThenTheEnabledConditions) {
  std::vector<std::string> names;
  for (const Mode& mode : evaluation_modes(true, true)) names.push_back(mode.name());
  EXPECT_EQ(names, kModes);
  EXPECT_EQ(evaluation_modes(false, false).size(), 1u);
  ASSERT_EQ(evaluation_modes(false, true).size(), 2u);
  EXPECT_EQ(evaluation_modes(false, true)[1].name(), "+D");
}

TEST_F(RunnerTest, SparseDepthSamplingIsDeterministic) {
  const auto sample = data::read_sample((*root_ / "pano" / "0").string());
  const Mode mode{false, true};
  const uint64_t seed = sample_seed("pano/0", 0);
  EXPECT_EQ(seed, sample_seed("pano/0", 0));
  EXPECT_NE(seed, sample_seed("pano/1", 0));
  EXPECT_NE(seed, sample_seed("pano/0", 1));
  const at::Tensor a = make_conditions(sample, mode, 40, seed).sparse_depth;
  const at::Tensor b = make_conditions(sample, mode, 40, seed).sparse_depth;
  const at::Tensor c = make_conditions(sample, mode, 40, seed + 1).sparse_depth;
  EXPECT_TRUE(at::equal(a, b));
  EXPECT_FALSE(at::equal(a, c));
  EXPECT_EQ((a > 0).sum().item<int64_t>(), 40);
  // The samples are GT distances at valid pixels.
  EXPECT_TRUE(at::equal(at::where(a > 0, sample.distance, at::zeros_like(a)), a));
  EXPECT_FALSE(((a > 0) & ~sample.mask).any().item<bool>());
  EXPECT_FALSE(make_conditions(sample, Mode{}, 40, seed).sparse_depth.defined());
  EXPECT_TRUE(make_conditions(sample, Mode{true, false}, 40, seed).rays.defined());
}

TEST_F(RunnerTest, OracleScoresPerfectlyOnEverySplitAndMode) {
  const RunResult& result = *oracle_;
  const Summary& summary = result.summary;
  EXPECT_EQ(summary.samples_total, 6);
  EXPECT_EQ(summary.samples_evaluated, 6);
  EXPECT_TRUE(summary.skipped.empty());
  EXPECT_EQ(summary.modes, kModes);
  EXPECT_EQ(result.records.size(), 6u * 4u);
  ASSERT_EQ(summary.scores.size(), 3u);
  for (const Split split : kSplits) {
    ASSERT_TRUE(summary.scores.count(split_name(split))) << split_name(split);
    for (const auto& mode : kModes) {
      const SplitScores& scores = summary.scores.at(split_name(split)).at(mode);
      EXPECT_EQ(scores.samples, 2);
      EXPECT_EQ(scores.entries.size(), kMetricEntries.size());
      for (const auto& [entry, score] : scores.entries) {
        SCOPED_TRACE(split_name(split) + " " + mode + " " + entry);
        EXPECT_EQ(score.count, 2);
        EXPECT_EQ(score.excluded, 0);
        EXPECT_NEAR(score.rel, 0.0, 1e-5);
        EXPECT_DOUBLE_EQ(score.delta1, 1.0);
      }
    }
  }
}

TEST_F(RunnerTest, ConstantDistanceScoresWorseThanTheOracle) {
  RunOptions options;
  const RunResult result =
      run_benchmark(constant_distance_predictor(5.0), {root_->string()}, options);
  for (const Split split : kSplits) {
    const auto& entries = result.summary.scores.at(split_name(split)).at("none").entries;
    SCOPED_TRACE(split_name(split));
    EXPECT_GT(entries.at("depth_scale_invariant").rel, 0.05);
    EXPECT_LT(entries.at("points_scale_invariant").delta1, 1.0);
    EXPECT_LT(entries.at("points_metric").delta1, 1.0);
  }
  EXPECT_THROW(constant_distance_predictor(0.0), std::invalid_argument);
}

TEST_F(RunnerTest, ConstantDistanceTakesTheMedianOfTheSparseDepth) {
  const auto sample = data::read_sample((*root_ / "sfov" / "1").string());
  const EvalSample item{"d", "sfov/1", Split::kSmallFov, sample};
  const Conditions conditions = make_conditions(sample, Mode{false, true}, 9, 5);
  const double median =
      conditions.sparse_depth.masked_select(conditions.sparse_depth > 0).median().item<double>();
  const Predictor constant = constant_distance_predictor(5.0);
  EXPECT_TRUE(at::equal(constant.predict(item, conditions).distance,
                        at::full_like(sample.distance, median)));
  EXPECT_TRUE(at::equal(constant.predict(item, Conditions{}).distance,
                        at::full_like(sample.distance, 5.0)));
}

TEST(RunnerScoring, PanoramaDepthIsTheDistanceSoPointsBehindTheCameraCount) {
  // A sphere of radius 2 around a panorama camera: half the points have z <= 0. Planar depth
  // would drop them; the distance keeps every pixel, and a scaled prediction is exactly
  // recovered by the scale-invariant entries.
  const auto camera = camera::parse_camera("EQUIRECTANGULAR 32 16");
  const auto rays = camera.ray_map(at::kFloat);
  data::Sample sample{camera, at::zeros({16, 32, 3}), at::full({16, 32}, 2.0f),
                      at::ones({16, 32}, at::kBool), true};
  GeometryPrediction prediction{rays.rays, at::full({16, 32}, 3.0f), 1.0, true};
  const Metrics metrics = score_sample(sample, Split::kPanorama, prediction);
  EXPECT_EQ(metrics.num_valid_pixels, 16 * 32);
  EXPECT_NEAR(metrics.entries.at("depth_scale_invariant").rel, 0.0, 1e-6);
  EXPECT_NEAR(metrics.entries.at("points_scale_invariant").rel, 0.0, 1e-6);
  EXPECT_NEAR(metrics.entries.at("depth_metric").rel, 0.5, 1e-6);
  EXPECT_THROW(
      score_sample(sample, Split::kPanorama, GeometryPrediction{rays.rays, at::ones({8, 8})}),
      std::invalid_argument);
}

TEST(RunnerScoring, PointMapsGiveRaysAndDistances) {
  const at::Tensor points = at::tensor({0.0f, 0.0f, 2.0f, 3.0f, 4.0f, 0.0f, 0.0f, 0.0f, 0.0f,
                                        std::numeric_limits<float>::quiet_NaN(), 0.0f, 1.0f})
                                .reshape({1, 4, 3});
  const GeometryPrediction prediction = prediction_from_points(points, true);
  EXPECT_TRUE(
      at::allclose(prediction.distance, at::tensor({2.0f, 5.0f, 0.0f, 0.0f}).reshape({1, 4})));
  EXPECT_TRUE(at::allclose(prediction.rays[0][1], at::tensor({0.6f, 0.8f, 0.0f})));
  EXPECT_TRUE(at::equal(prediction.rays[0][3], at::zeros({3})));
  EXPECT_FALSE(at::isnan(prediction.rays).any().item<bool>());
}

// +K: the known camera's rays carry the model's distances (as `omnipoint predict --camera`).
TEST(RunnerScoring, OmniPointModelUsesAKnownCameraAsItIs) {
  const auto config = model::OmniPointConfig::from_json_text(
      io::read_file(std::string(OMNIPOINT_SOURCE_DIR) + "/examples/models/tiny_omnipoint.json"));
  at::manual_seed(0);
  Predictor predictor =
      network_predictor(infer::Network(model::OmniPointModel(config)), "tiny", 12);
  const camera::Camera fisheye = camera::parse_camera("OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0");
  const camera::Rays truth = fisheye.ray_map(at::kFloat);
  const EvalSample item{
      "data", "0000", Split::kLargeFov,
      data::Sample{fisheye, at::rand({28, 28, 3}), at::ones({28, 28}), truth.valid, true}};
  Conditions known;
  known.rays = truth.rays;
  EXPECT_TRUE(at::allclose(predictor.predict(item, known).rays, truth.rays));
  EXPECT_FALSE(at::allclose(predictor.predict(item, Conditions{}).rays, truth.rays, 1e-2, 1e-2));
}

TEST_F(RunnerTest, SummaryAndTableHaveTheRightRowsAndColumns) {
  const RunResult& oracle = *oracle_;
  const RunResult constant =
      run_benchmark(constant_distance_predictor(5.0), {root_->string()}, RunOptions{});
  const std::string table = markdown_table({oracle.summary, constant.summary});
  std::vector<std::string> lines;
  std::stringstream stream(table);
  for (std::string line; std::getline(stream, line);) lines.push_back(line);
  ASSERT_EQ(lines.size(), 2u + 4u + 1u);  // header, rule, 4 oracle modes, 1 constant mode
  for (const char* split : {"S.FoV", "L.FoV", "360°"})
    for (const char* column : {"depth Rel", "depth δ1", "points Rel", "points δ1", "metric δ1"})
      EXPECT_NE(lines[0].find(std::string(split) + " " + column), std::string::npos)
          << split << column;
  EXPECT_LT(lines[0].find("S.FoV"), lines[0].find("L.FoV"));
  EXPECT_LT(lines[0].find("L.FoV"), lines[0].find("360°"));
  EXPECT_EQ(
      lines[2],
      "| oracle (GT rays and distances) | none | 0.00 | 100.0 | 0.00 | 100.0 | 100.0 | 0.00 | "
      "100.0 | 0.00 | 100.0 | 100.0 | 0.00 | 100.0 | 0.00 | 100.0 | 100.0 |");
  EXPECT_EQ(lines[5].rfind("| oracle (GT rays and distances) | +K+D |", 0), 0u);
  EXPECT_EQ(lines[6].rfind("| constant distance 5 m (GT rays) | none |", 0), 0u);

  const auto json = nlohmann::json::parse(summary_json(oracle.summary));
  EXPECT_EQ(json["samples_evaluated"], 6);
  EXPECT_EQ(json["sparse_depth_points"], 50);
  EXPECT_EQ(json["modes"].size(), 4u);
  EXPECT_EQ(json["scores"]["360°"]["+K+D"]["entries"]["points_metric"]["delta1"], 1.0);
  EXPECT_EQ(json["scores"]["L.FoV"]["none"]["samples"], 2);
  for (const auto& record : oracle.records) {
    const auto line = nlohmann::json::parse(record);
    EXPECT_TRUE(line.contains("split") && line.contains("mode") && line.contains("entries"))
        << record;
  }
}

TEST_F(RunnerTest, ModesAPredictorCannotTakeAreReportedNotRun) {
  Predictor image_only = oracle_predictor();
  image_only.accepts_intrinsics = image_only.accepts_sparse_depth = false;
  const RunResult result = run_benchmark(image_only, {root_->string()}, all_modes());
  EXPECT_EQ(result.summary.modes, std::vector<std::string>{"none"});
  EXPECT_EQ(result.summary.modes_not_supported, (std::vector<std::string>{"+K", "+D", "+K+D"}));
  EXPECT_EQ(result.records.size(), 6u);
}

TEST_F(RunnerTest, NonFinitePredictionsAreExcludedAndCounted) {
  Predictor broken = oracle_predictor();
  broken.predict = [](const EvalSample& item, const Conditions&) {
    GeometryPrediction p{
        item.sample.camera.ray_map(at::kFloat).rays,
        at::full_like(item.sample.distance, std::numeric_limits<float>::quiet_NaN()), 1.0, true};
    if (item.id.find("/0") == std::string::npos) p.distance = item.sample.distance;
    return p;
  };
  const RunResult result = run_benchmark(broken, {root_->string()}, RunOptions{});
  for (const Split split : kSplits) {
    const AveragedScore& score =
        result.summary.scores.at(split_name(split)).at("none").entries.at("depth_scale_invariant");
    EXPECT_EQ(score.count, 1);
    EXPECT_EQ(score.excluded, 1);
    EXPECT_NEAR(score.rel, 0.0, 1e-5);
  }
  EXPECT_NE(markdown_table({result.summary}).find("| 0.00 |"), std::string::npos);
}

TEST(RunnerBadInputs, MissingOrEmptyDatasetsAreErrors) {
  const fs::path empty =
      fs::temp_directory_path() / ("omnipoint_eval_empty_" + std::to_string(::getpid()));
  fs::create_directories(empty / "nothing_here");
  EXPECT_THROW(run_benchmark(oracle_predictor(), {(empty / "missing").string()}, RunOptions{}),
               std::runtime_error);
  try {
    run_benchmark(oracle_predictor(), {empty.string()}, RunOptions{});
    FAIL() << "no error for an empty dataset";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("no samples found"), std::string::npos) << e.what();
  }
  EXPECT_THROW(run_benchmark(oracle_predictor(), {}, RunOptions{}), std::invalid_argument);
  fs::remove_all(empty);
}

// A sample still being written (or left by a killed `synth`) sits in a staging folder
// (io::StagedFolder): even with every file in it, it is no sample yet.
TEST(RunnerDatasets, StagingFoldersAreNotListed) {
  const fs::path root = testing::make_tiny_dataset("staging", 1);
  fs::copy(root / "sfov" / "0", root / "sfov" / ".1.partial-Ab12cd", fs::copy_options::recursive);
  const std::vector<data::DatasetItem> items = data::list_dataset(root.string());
  ASSERT_EQ(items.size(), 3u);
  for (const data::DatasetItem& item : items)
    EXPECT_EQ(item.id.find("partial"), std::string::npos) << item.id;
  fs::remove_all(root);
}

TEST(RunnerBadInputs, BadSamplesAndMissingPredictionsAreSkippedAndCounted) {
  const fs::path root = testing::make_tiny_dataset("bad_samples", 1);
  std::ofstream(root / "lfov" / "0" / "distance.npy") << "not an npy file";
  Predictor picky = oracle_predictor();
  const auto inner = picky.predict;
  picky.predict = [inner](const EvalSample& item, const Conditions& conditions) {
    if (item.id == "pano/0") throw MissingPrediction("no prediction for pano/0");
    return inner(item, conditions);
  };
  const RunResult result = run_benchmark(picky, {root.string()}, RunOptions{});
  EXPECT_EQ(result.summary.samples_total, 3);
  EXPECT_EQ(result.summary.samples_evaluated, 1);
  EXPECT_EQ(result.summary.skipped.at("unreadable sample"), 1);
  EXPECT_EQ(result.summary.skipped.at("missing prediction"), 1);
  EXPECT_EQ(result.summary.scores.size(), 1u);
  int skip_records = 0;
  for (const auto& record : result.records)
    skip_records += nlohmann::json::parse(record).contains("skipped");
  EXPECT_EQ(skip_records, 2);
  fs::remove_all(root);
}

// Three training samples of one pinhole: distances 1, 2 (row 0 unlabelled) and 6 everywhere.
// The per-pixel median is 2, and 1 on row 0 (the lower middle of {1, 6}, torch's median).
TEST(MedianMapBaseline, IsThePerPixelMedianOfTheTrainingSamplesOfTheCamera) {
  const fs::path root =
      fs::temp_directory_path() / ("omnipoint_eval_median_" + std::to_string(::getpid()));
  fs::remove_all(root);
  const auto pinhole = camera::parse_camera("PINHOLE 8 6 6 6 4 3");
  const auto write = [&](const std::string& name, double value, bool label_row0) {
    data::Sample sample{pinhole, at::full({6, 8, 3}, 0.5F), at::full({6, 8}, value, at::kFloat),
                        at::ones({6, 8}, at::kBool), true};
    if (!label_row0) {
      sample.mask[0].fill_(false);
      sample.distance[0].fill_(0.0);
    }
    data::write_sample((root / "train" / name).string(), sample);
  };
  write("a", 1.0, true);
  write("b", 2.0, false);
  write("c", 6.0, true);
  const Predictor median = median_map_predictor({(root / "train").string()});
  const data::Sample sample = data::read_sample((root / "train" / "a").string());
  const EvalSample item{"d", "a", Split::kSmallFov, sample};
  const GeometryPrediction prediction = median.predict(item, Conditions{});
  at::Tensor expected = at::full({6, 8}, 2.0F);
  expected[0].fill_(1.0);
  EXPECT_TRUE(at::equal(prediction.distance, expected)) << prediction.distance;
  EXPECT_TRUE(prediction.is_metric);
  EXPECT_TRUE(at::allclose(prediction.rays, pinhole.ray_map(at::kFloat).rays));
  // +D: rescaled by the median ratio of the samples to the map (here 3 at every sample).
  Conditions conditions;
  conditions.sparse_depth = at::zeros({6, 8});
  conditions.sparse_depth[2][3] = 6.0;
  conditions.sparse_depth[4][5] = 6.0;
  conditions.sparse_depth[0][1] = 3.0;
  EXPECT_TRUE(at::allclose(median.predict(item, conditions).distance, expected * 3.0));
  // Another camera: no map, the sample is skipped as a missing prediction.
  data::Sample other = sample;
  other.camera = camera::parse_camera("PINHOLE 8 6 5 5 4 3");
  EXPECT_THROW(median.predict(EvalSample{"d", "x", Split::kSmallFov, other}, Conditions{}),
               MissingPrediction);
  EXPECT_THROW(median_map_predictor({(root / "missing").string()}), std::runtime_error);
  fs::remove_all(root);
}

}  // namespace
}  // namespace omnipoint::eval
