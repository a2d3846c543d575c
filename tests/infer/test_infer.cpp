// infer::run, the one inference path: the format dispatch, the metric post-alignment, and the
// equality of what `omnipoint eval` scores (eval::network_predictor) with what `omnipoint
// predict` ships (predict::Model) for both checkpoint formats, three camera kinds and the four
// condition modes.
#include <gtest/gtest.h>

#include <ATen/ATen.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/eval/predictors.h"
#include "omnipoint/eval/runner.h"
#include "omnipoint/infer/infer.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/predict/predictor.h"
#include "support/fast_synth.h"
#include "support/tiny_omnipoint.h"

namespace omnipoint::infer {
namespace {

const std::string kBundled =
    std::string(OMNIPOINT_SOURCE_DIR) + "/models/omnipoint_default.safetensors";
const std::string kMoGe2 =
    std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a/model.safetensors";

TEST(Infer, LoadNetworkDispatchesOnTheFormat) {
  EXPECT_EQ(load_network(kBundled).format(), "omnipoint");
  EXPECT_EQ(load_network(kBundled).default_num_tokens(), 64);
  EXPECT_EQ(load_network(kMoGe2).format(), "moge2");
  // Errors name the path: unreadable -> runtime_error, not a model we know -> invalid_argument.
  const auto message = [](const auto& load) {
    try {
      load();
    } catch (const std::exception& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "infer_load";
  std::filesystem::create_directories(dir);
  const std::string missing = (dir / "missing.safetensors").string();
  EXPECT_THROW(load_network(missing), std::runtime_error);
  EXPECT_NE(message([&] { load_network(missing); }).find(missing), std::string::npos);
  const io::SafetensorsFile file = io::read_safetensors(kMoGe2);
  auto metadata = file.metadata;
  metadata["format"] = "other";
  const std::string other = (dir / "other.safetensors").string();
  io::write_safetensors(other, file.tensors, metadata);
  EXPECT_THROW(load_network(other), std::invalid_argument);
  EXPECT_NE(message([&] { load_network(other); }).find(other), std::string::npos);
  metadata.erase("format");
  metadata.erase("config");
  const std::string bare = (dir / "bare.safetensors").string();
  io::write_safetensors(bare, file.tensors, metadata);
  EXPECT_THROW(load_network(bare), std::invalid_argument);
  EXPECT_NE(message([&] { load_network(bare); }).find(bare), std::string::npos);
}

// Moved from model/test_omnipoint_model.cpp (model::align_to_metric_sparse_depth): a model
// without a sparse-depth branch, so the sparse depth only aligns and the runs are comparable.
TEST(Infer, MetricPostAlignmentRescalesToTheSparseDepth) {
  at::manual_seed(0);
  const Network network(model::OmniPointModel(model::OmniPointConfig::from_json_text(
      test::tiny_omnipoint_config_json("ray_distance", R"({"sparse_depth": false})"))));
  Inputs inputs;
  inputs.images = at::rand({2, 3, 30, 40});
  inputs.num_tokens = 12;
  const Result out = run(network, inputs);
  // Item 0: samples at 3× the predicted metric distance; item 1: none.
  const at::Tensor metric_distance = out.metric_scale.view({2, 1, 1}) * out.distance;
  // The shipped map carries the metric distance, zero outside its mask.
  ASSERT_GT(out.shipped.mask.sum().item<int64_t>(), 0);
  EXPECT_TRUE(at::equal(out.shipped.distance, at::where(out.shipped.mask, metric_distance,
                                                        at::zeros_like(metric_distance))));
  const at::Tensor keep = at::rand({2, 30, 40}) < 0.02;
  at::Tensor sparse = at::where(keep, 3.0 * metric_distance, at::zeros_like(metric_distance));
  sparse[1].zero_();
  inputs.sparse_distance = sparse;
  const Result aligned = run(network, inputs);
  EXPECT_TRUE(aligned.aligned);
  EXPECT_NEAR(aligned.metric_scale[0].item<double>(), 3.0 * out.metric_scale[0].item<double>(),
              1e-5);
  EXPECT_NEAR(aligned.alignment_factor[0].item<double>(), 3.0, 1e-5);
  EXPECT_EQ(aligned.metric_scale[1].item<double>(), out.metric_scale[1].item<double>());
  EXPECT_LT((aligned.shipped.points[0] - 3.0 * out.shipped.points[0]).abs().max().item<double>(),
            1e-4);
  EXPECT_TRUE(at::equal(aligned.shipped.points[1], out.shipped.points[1]));
  EXPECT_EQ(aligned.sparse_samples[1].item<int64_t>(), 0);
  inputs.sparse_distance = sparse.narrow(1, 0, 10);
  EXPECT_THROW(run(network, inputs), std::invalid_argument);
}

// What eval scores is what predict ships: the point map eval scores (eval::scored_points)
// equals predict's points at every pixel (zero where predict's mask is false), in every mode
// eval runs the network in.
TEST(Infer, EvalScoresWhatPredictShips) {
  const std::vector<std::string> cameras = {"PINHOLE 42 28 30 30 21 14",
                                            "OPENCV_FISHEYE 32 32 9.6 9.6 16 16 0 0 0 0",
                                            "EQUIRECTANGULAR 48 24"};
  for (const std::string& path : {kBundled, kMoGe2}) {
    const predict::Model model = predict::Model::load(path);
    // The bundled model at its default budget (0 on both sides); the MoGe-2 fixture's default
    // (3,600 tokens) is too slow for a unit test.
    const int64_t tokens = model.format() == "moge2" ? 16 : 0;
    const eval::Predictor predictor = eval::network_predictor(model.network(), "m", tokens);
    for (const std::string& spec : cameras) {
      const camera::Camera camera = camera::parse_camera(spec);
      const data::Sample sample =
          data::synth::synthesize(data::synth::SceneKind::kIndoor, 3, camera, test::fast_synth())
              .sample;
      const eval::EvalSample item{"data", "0000", eval::camera_split(camera), sample};
      for (const eval::Mode& mode : eval::evaluation_modes(true, true)) {
        const std::string what = path + " " + spec + " " + mode.name();
        if ((mode.intrinsics && !predictor.accepts_intrinsics) ||
            (mode.sparse_depth && !predictor.accepts_sparse_depth)) {
          EXPECT_EQ(model.format(), "moge2") << what;  // MoGe-2 takes no camera
          continue;
        }
        const eval::Conditions conditions = eval::make_conditions(sample, mode, 20, 7);
        const eval::GeometryPrediction scored = predictor.predict(item, conditions);
        const at::Tensor eval_points = eval::scored_points(scored);

        predict::PredictOptions options;
        options.num_tokens = tokens;
        options.fit_model = "";
        options.edge_rtol = 0;  // eval scores without predict's flying-pixel filter (as MoGe's)
        if (mode.intrinsics) options.camera = camera;
        if (mode.sparse_depth) {
          options.sparse_depth.depth_map = conditions.sparse_depth;
          options.sparse_depth.depth_is_planar = false;
        }
        const predict::Prediction shipped = model.predict(sample.image, options);
        ASSERT_TRUE(shipped.mask.any().item<bool>()) << what;
        const at::Tensor mask = shipped.mask.unsqueeze(-1);
        EXPECT_LE((eval_points - shipped.points).abs().max().item<double>(), 1e-6) << what;
        EXPECT_NEAR(scored.metric_scale, shipped.metric_scale, 1e-6 * shipped.metric_scale) << what;
        EXPECT_EQ(shipped.points.masked_select(~mask).abs().sum().item<double>(), 0.0) << what;
      }
    }
  }
}

}  // namespace
}  // namespace omnipoint::infer
