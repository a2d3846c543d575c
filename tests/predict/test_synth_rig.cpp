// `omnipoint synth --rig` (data::synth::write_rig_frames): a rig rendered in a procedural scene
// as frames that `predict --rig` reads, with the truth beside them. The truth must be the
// geometry (every camera's surface points agree where the views overlap, the LiDAR's returns lie
// on the surfaces the cameras see), the set must be whole or resumed, and bad input one error.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/rig_render.h"
#include "omnipoint/geometry/alignment.h"
#include "omnipoint/io/point_cloud.h"
#include "omnipoint/io/rig.h"
#include "omnipoint/predict/inputs.h"
#include "omnipoint/predict/rig_eval.h"
#include "omnipoint/predict/rig_overlap.h"
#include "predict/rig_poses.h"
#include "support/cli_run.h"
#include "support/expect_error.h"
#include "support/scratch_dir.h"

namespace omnipoint::data::synth {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using predict::test_rig::pose;
using predict::test_rig::pose_rows;
using predict::test_rig::rotation_x;
using predict::test_rig::rotation_y;

// A pinhole, a fisheye of more than 180 degrees and a panorama on a vehicle body (x forward,
// y left, z up), and a LiDAR on the roof.
std::string vehicle_rig() {
  // The camera frame (x right, y down, z forward) looking along the body's x.
  const at::Tensor forward =
      at::tensor({0.0, 0.0, 1.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0}, at::kDouble).view({3, 3});
  return json{
      {"frame", "vehicle"},
      {"cameras",
       {{{"name", "front"},
         {"camera", "PINHOLE 40 30 30 30 20 15"},
         {"body_from_camera", pose_rows(pose(forward, {1.5, 0.0, 1.4}))}},
        {{"name", "left"},
         {"camera", "MEI 32 32 16 16 16 16 1.35 0 0 0 0"},
         {"body_from_camera",
          pose_rows(pose(forward.matmul(rotation_y(-M_PI / 2)), {0.5, 0.9, 1.0}))}},
        {{"name", "pano"},
         {"camera", "EQUIRECTANGULAR 48 24"},
         {"body_from_camera", pose_rows(pose(forward.matmul(rotation_x(0.1)), {0.0, 0.0, 1.8}))}}}},
      {"lidar",
       {{"format", "kitti"},
        {"body_from_lidar", pose_rows(pose(at::eye(3, at::kDouble), {0.2, 0.0, 1.9}))}}}}
      .dump();
}

RigFramesOptions small_options(const fs::path& rig) {
  RigFramesOptions options;
  options.rig = rig.string();
  options.scene = SceneKind::kOutdoor;
  options.seed = 5;
  options.frames = 2;
  options.render.body_axes = BodyAxes::kVehicle;
  options.render.synth.render.shadows = false;
  options.render.synth.render.ambient_occlusion = false;
  options.render.lidar = true;
  options.render.lidar_pattern.beams = 16;
  options.render.lidar_pattern.azimuth_steps = 360;
  return options;
}

TEST(SynthRig, WritesFramesThatPredictReadsAndTheirTruth) {
  const fs::path dir = test::fresh_process_dir("omnipoint_synth_rig");
  std::ofstream(dir / "rig.json") << vehicle_rig();
  const RigFramesOptions options = small_options(dir / "rig.json");
  std::vector<std::string> written;
  const RigFramesSummary summary = write_rig_frames(
      (dir / "set").string(), options, [&](const std::string& f) { written.push_back(f); });
  EXPECT_EQ(summary.frames, (std::vector<std::string>{"000000", "000001"}));
  EXPECT_EQ(summary.rendered, 2);
  EXPECT_EQ(written.size(), 2u);
  EXPECT_GT(summary.lidar_points, 500);
  const io::Rig rig = io::read_rig((dir / "set" / "rig.json").string());
  ASSERT_EQ(rig.cameras.size(), 3u);
  ASSERT_TRUE(rig.lidar);

  for (const std::string& frame : summary.frames) {
    SCOPED_TRACE(frame);
    const fs::path images = dir / "set" / "frames" / frame;
    std::vector<predict::OverlapCamera> views;
    for (const io::RigCamera& camera : rig.cameras) {
      SCOPED_TRACE(camera.name);
      EXPECT_TRUE(fs::is_regular_file(images / (camera.name + ".png")));
      const Sample truth = read_sample((dir / "set" / "truth" / frame / camera.name).string());
      EXPECT_EQ(truth.camera, camera.camera);
      EXPECT_TRUE(truth.metric);
      EXPECT_GT(truth.mask.sum().item<int64_t>(), truth.mask.numel() / 4);
      views.push_back({camera.camera, camera.body_from_camera,
                       camera.camera.ray_map(at::kDouble).rays, truth.distance, truth.mask, 1.0,
                       false});
    }
    // The cameras' truths are one scene: where they overlap they agree.
    const predict::OverlapResult overlap = predict::measure_overlaps(views);
    ASSERT_TRUE(overlap.residual);
    EXPECT_LT(*overlap.residual, 2e-3);
    // The sweep's returns, through body_from_lidar and a camera's pose, land on that camera's
    // surface where it sees them (KITTI layout: x, y, z, reflectance).
    const at::Tensor sweep =
        io::read_point_cloud((images / "lidar.bin").string(), 4, "sweep").to(at::kDouble);
    for (const io::RigCamera& camera : rig.cameras) {
      SCOPED_TRACE(camera.name);
      const at::Tensor camera_from_lidar =
          at::linalg_inv(camera.body_from_camera).matmul(rig.lidar->body_from_lidar);
      const at::Tensor in_camera =
          sweep.matmul(camera_from_lidar.slice(0, 0, 3).slice(1, 0, 3).t()) +
          camera_from_lidar.slice(0, 0, 3).select(1, 3);
      const camera::Pixels pixels = camera.camera.project(in_camera);
      const at::Tensor truth = read_sample((dir / "set" / "truth" / frame / camera.name).string())
                                   .distance.to(at::kDouble);
      const at::Tensor inside = pixels.valid & camera.camera.inside_image(pixels.pixels);
      const at::Tensor px = pixels.pixels.index({inside}).floor().to(at::kLong).clamp_min(0);
      const at::Tensor at_pixel = truth.index({px.select(1, 1).clamp_max(truth.size(0) - 1),
                                               px.select(1, 0).clamp_max(truth.size(1) - 1)});
      const at::Tensor range = in_camera.index({inside}).norm(2, -1);
      const at::Tensor seen = at_pixel > 0;
      ASSERT_GT(seen.sum().item<int64_t>(), 20);
      // The median return lies on the surface within a pixel's depth step (no scale between).
      const double ratio = (range.index({seen}) / at_pixel.index({seen})).median().item<double>();
      EXPECT_NEAR(ratio, 1.0, 0.02);
      std::printf("frame %s: overlap residual of the truth %.2e, %s: LiDAR / truth %.4f\n",
                  frame.c_str(), *overlap.residual, camera.name.c_str(), ratio);
    }
  }

  // A rerun keeps the frames that exist and renders a missing one.
  fs::remove_all(dir / "set" / "frames" / "000001");
  const RigFramesSummary again = write_rig_frames((dir / "set").string(), options);
  EXPECT_EQ(again.kept, 1);
  EXPECT_EQ(again.rendered, 1);
  EXPECT_TRUE(fs::is_regular_file(dir / "set" / "frames" / "000001" / "lidar.bin"));
}

TEST(SynthRig, BadInputIsOneErrorAndWritesNothing) {
  const fs::path dir = test::fresh_process_dir("omnipoint_synth_rig_bad");
  json rig = json::parse(vehicle_rig());
  rig.erase("lidar");
  std::ofstream(dir / "no_lidar.json") << rig.dump();
  RigFramesOptions options = small_options(dir / "no_lidar.json");
  test::expect_error<std::invalid_argument>(
      [&] { write_rig_frames((dir / "set").string(), options); }, {"--lidar", "no lidar"});
  EXPECT_FALSE(fs::exists(dir / "set"));
  options.render.lidar = false;
  options.frames = 0;
  test::expect_error<std::invalid_argument>(
      [&] { write_rig_frames((dir / "set").string(), options); }, {"--count"});
  EXPECT_FALSE(fs::exists(dir / "set"));

  // The command: one error line.
  const test::CliRun run = test::run_omnipoint("synth --rig " + (dir / "no_lidar.json").string() +
                                                   " --lidar --out " + (dir / "cli").string(),
                                               dir);
  EXPECT_NE(run.status, 0);
  std::istringstream lines(run.err);
  int errors = 0;
  for (std::string line; std::getline(lines, line);)
    if (line.find("error") != std::string::npos) ++errors;
  EXPECT_EQ(errors, 1) << run.err;
  EXPECT_NE(run.err.find("no lidar"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir / "cli"));
}

TEST(SynthRig, TheCommandWritesASetThatPredictReads) {
  const fs::path dir = test::fresh_process_dir("omnipoint_synth_rig_cli");
  std::ofstream(dir / "rig.json") << vehicle_rig();
  const test::CliRun run = test::run_omnipoint(
      "synth --rig " + (dir / "rig.json").string() +
          " --scene outdoor --seed 3 --count 1 --body-axes vehicle --no-shadows --no-ao --lidar "
          "--lidar-beams 8 --lidar-azimuth-steps 180 --out " +
          (dir / "set").string(),
      dir);
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.out.find("000000"), std::string::npos) << run.out;
  for (const char* file : {"front.png", "left.png", "pano.png", "lidar.bin"})
    EXPECT_TRUE(fs::is_regular_file(dir / "set" / "frames" / "000000" / file)) << file;
  EXPECT_TRUE(fs::is_regular_file(dir / "set" / "truth" / "000000" / "pano" / "distance.npy"));
}

// `eval --rig` (predict::evaluate_rig) on a synth --rig set, with the truth in place of the
// network whose distances are off by a known factor per camera: the scale errors are those
// factors' (exactly), the overlap rule brings the cameras to the truth's scale (spread ~0,
// residual ~0), the median rule leaves their spread, the LiDAR rule comes within 5 %.
TEST(SynthRig, EvalScoresTheRulesAgainstTheTruth) {
  const fs::path dir = test::fresh_process_dir("omnipoint_synth_rig_eval");
  std::ofstream(dir / "rig.json") << vehicle_rig();
  RigFramesOptions set = small_options(dir / "rig.json");
  set.frames = 1;
  write_rig_frames((dir / "set").string(), set);
  // The middle two multiply to 1: the overlap rule's level is the truth's.
  const std::map<std::string, double> off = {{"front", 0.8}, {"left", 1.25}, {"pano", 1.0}};
  predict::RigEvalOptions options;
  options.job.rig = (dir / "set" / "rig.json").string();
  options.job.frames_dir = (dir / "set" / "frames").string();
  options.job.output_dir = (dir / "eval").string();
  options.job.predictor = [&](const predict::RigCameraImage& image,
                              const predict::PredictOptions& given) {
    const Sample truth = read_sample((dir / "set" / "truth" / image.frame / image.camera).string());
    const at::Tensor rays = truth.camera.ray_map(at::kFloat).rays;
    const at::Tensor distance = truth.distance * off.at(image.camera);
    double factor = 1;
    int64_t samples = 0;
    if (!given.sparse_depth.empty()) {
      const at::Tensor sparse = predict::sparse_distance_map(
          given.sparse_depth, truth.camera.width(), truth.camera.height(), rays, &*given.camera);
      const at::Tensor usable = (sparse > 0) & truth.mask;
      samples = usable.sum().item<int64_t>();
      factor = geometry::fit_scale_to_sparse_depth(distance.flatten(), sparse.flatten(),
                                                   usable.flatten())
                   .item<double>();
    }
    predict::Prediction p =
        predict::prediction_from_geometry(rays, distance * factor, truth.mask, factor);
    p.sparse_samples = samples;
    p.fitted_camera = given.camera;
    return p;
  };
  const predict::RigEvalResult result = predict::evaluate_rig(options);
  ASSERT_EQ(result.rules.size(), 3u);
  EXPECT_EQ(result.rules[0].name, "lidar");
  EXPECT_EQ(result.rules[1].name, "overlap");
  EXPECT_EQ(result.rules[2].name, "independent");
  EXPECT_TRUE(fs::is_regular_file(result.report_path));
  const json report = json::parse(test::slurp(result.report_path));
  EXPECT_EQ(report["rules"].size(), 3u);
  std::printf("%s", result.table.c_str());
  for (const predict::RigEvalRule& rule : result.rules) {
    SCOPED_TRACE(rule.name);
    ASSERT_EQ(rule.frames.size(), 1u);
    const predict::RigEvalFrame& frame = rule.frames[0];
    ASSERT_EQ(frame.cameras.size(), 3u);
    ASSERT_TRUE(frame.overlap_residual);
    for (const predict::RigEvalCamera& camera : frame.cameras) {
      SCOPED_TRACE(camera.name);
      // The network's distances are the truth times the factor: the true scale is 1 / factor.
      EXPECT_NEAR(camera.true_scale * off.at(camera.name), 1.0, 1e-4);
      EXPECT_NEAR(camera.error, camera.scale / camera.true_scale - 1, 1e-12);
      if (rule.name == "independent")  // the network's own scale: 1
        EXPECT_NEAR(camera.error, off.at(camera.name) - 1, 1e-4);
      else if (rule.name == "overlap")  // the truth
        EXPECT_NEAR(camera.error, 0.0, 1e-5);
      else  // a 16-beam sweep from the roof into 8°-pixels of a 32-pixel fisheye: a few
            // returns per pixel, none at its centre
        EXPECT_NEAR(camera.error, 0.0, 0.05);
    }
    if (rule.name == "independent") {
      EXPECT_NEAR(frame.spread, 1.25 / 0.8 - 1, 1e-4);
      EXPECT_NEAR(*frame.overlap_residual, 0.25, 0.05);
    } else if (rule.name == "overlap") {
      EXPECT_LT(frame.spread, 1e-5);
      EXPECT_LT(*frame.overlap_residual, 1e-3);
    } else {
      EXPECT_LT(frame.spread, 0.2);
      EXPECT_LT(*frame.overlap_residual, 0.1);
    }
  }

  // --no-lidar: no LiDAR rule; a frame without truth: one error before any prediction.
  options.lidar = false;
  options.job.output_dir = (dir / "eval_no_lidar").string();
  EXPECT_EQ(predict::evaluate_rig(options).rules.size(), 2u);
  fs::remove_all(dir / "set" / "truth" / "000000");
  options.job.output_dir = (dir / "eval_no_truth").string();
  test::expect_error<std::invalid_argument>([&] { predict::evaluate_rig(options); },
                                            {"truth", "000000"});
  EXPECT_FALSE(fs::exists(dir / "eval_no_truth"));
}

}  // namespace
}  // namespace omnipoint::data::synth
