// `omnipoint predict --rig --sequence` (predict::RigPredictJob with sequence) on a rig's video
// rendered by `omnipoint synth --rig --path` (data::synth::write_rig_frames with path): the
// body's poses must follow the camera path; with the truth in the network's place and each
// frame's network scale off by a known factor, --scale smooth must change the applied rig scale
// less from frame to frame than per-frame, fixed must hold it, and the LiDAR-aligned cameras must
// keep their measured scales; an interrupted run must resume without redoing finished frames
// and end as an uninterrupted one; conflicting options: one error line, nothing written.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/camera_path.h"
#include "omnipoint/data/synth/rig_render.h"
#include "omnipoint/data/synth/scene.h"
#include "omnipoint/eval/temporal.h"
#include "omnipoint/geometry/alignment.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/predict/rig_predict_job.h"
#include "predict/rig_poses.h"
#include "predict/tiny_model.h"
#include "support/cli_run.h"
#include "support/expect_error.h"
#include "support/scratch_dir.h"

namespace omnipoint::predict {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using test_rig::pose;
using test_rig::pose_rows;
using test_rig::rotation_y;

constexpr int64_t kFrames = 6;
constexpr std::uint64_t kSeed = 5;
constexpr double kStep = 0.08, kYawDeg = 2.0;

// Two pinholes looking forward and back (their views do not overlap: both keep the rig scale
// of the median rule) and a LiDAR above them, its axes a vehicle's (x forward, y left, z up).
const std::map<std::string, at::Tensor>& mounts() {
  static const std::map<std::string, at::Tensor> poses = {
      {"front", pose(at::eye(3, at::kDouble), {0.0, 0.0, 0.2})},
      {"back", pose(rotation_y(M_PI), {0.0, 0.0, -0.2})}};
  return poses;
}

std::string rig_text() {
  json cameras = json::array();
  for (const auto& [name, body_from_camera] : mounts())
    cameras.push_back({{"name", name},
                       {"camera", "PINHOLE 80 60 64 64 40 30"},
                       {"body_from_camera", pose_rows(body_from_camera)}});
  return json{
      {"cameras", cameras},
      {"lidar",
       {{"format", "kitti"},
        {"body_from_lidar",
         pose_rows(pose(
             at::tensor({0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0}, at::kDouble).view({3, 3}),
             {0.0, -0.3, 0.0}))}}}}
      .dump();
}

// The rig's video, rendered once per process: ROOT/rig.json, ROOT/frames/<frame>/ (with the
// sweeps), ROOT/truth/<frame>/<camera>/.
const fs::path& rendered_path() {
  static const fs::path root = [] {
    const fs::path dir = test::fresh_process_dir("omnipoint_rig_sequence_render");
    std::ofstream(dir / "mounted.json") << rig_text();
    data::synth::RigFramesOptions options;
    options.rig = (dir / "mounted.json").string();
    options.seed = kSeed;
    options.frames = kFrames;
    options.path = true;
    options.path_step = kStep;
    options.path_yaw_deg = kYawDeg;
    options.render.synth.render.shadows = false;
    options.render.synth.render.ambient_occlusion = false;
    options.render.lidar = true;
    options.render.lidar_pattern.beams = 32;
    options.render.lidar_pattern.azimuth_steps = 360;
    data::synth::write_rig_frames((dir / "path").string(), options);
    return dir / "path";
  }();
  return root;
}

std::string frame_name(int64_t k) {
  char name[16];
  std::snprintf(name, sizeof name, "%06lld", static_cast<long long>(k));
  return name;
}

// Each frame's network scale: the truth's distances at a wrong metric scale that jumps from
// frame to frame (known factors), the back camera 1.25 times the front's.
double frame_factor(const std::string& frame) {
  static const double factors[kFrames] = {1.0, 1.3, 0.8, 1.25, 0.85, 1.2};
  return factors[std::stoi(frame)];
}
double camera_factor(const std::string& camera) {
  return camera == "back" ? 1.25 : 1.0;
}

// The ground truth in place of the network (its distances the truth's, its metric scale the
// frame's and camera's factors), then aligned to the sweep's points in its view as the model
// aligns (geometry/alignment.h). Counts its calls.
RigCameraPredictor oracle(int* calls) {
  return [calls](const RigCameraImage& image, const PredictOptions& options) {
    ++*calls;
    const fs::path truth = rendered_path() / "truth" / image.frame / image.camera;
    const data::Sample sample = data::read_sample(truth.string());
    const at::Tensor rays = io::read_npy((truth / "rays.npy").string());
    EXPECT_EQ(image.image.size(0), sample.mask.size(0));
    const double scale = frame_factor(image.frame) * camera_factor(image.camera);
    const at::Tensor distance = sample.distance * scale;
    double factor = 1;
    int64_t samples = 0;
    if (!options.sparse_depth.empty()) {
      const at::Tensor sparse = sparse_distance_map(options.sparse_depth, sample.mask.size(1),
                                                    sample.mask.size(0), rays, &*options.camera);
      const at::Tensor usable = (sparse > 0) & sample.mask;
      samples = usable.sum().item<int64_t>();
      if (samples > 0)
        factor = geometry::fit_scale_to_sparse_depth(distance.flatten(), sparse.flatten(),
                                                     usable.flatten())
                     .item<double>();
    }
    Prediction p = prediction_from_geometry(rays, distance * factor, sample.mask, scale * factor);
    p.alignment_factor = factor;
    p.sparse_samples = samples;
    p.fitted_camera = options.camera;
    p.camera_source = CameraSource::kGiven;
    return p;
  };
}

struct Counter : RigPredictJobObserver {
  std::vector<std::string> resumed, written;
  void frame_resumed(size_t /*index*/, const std::string& frame, double /*scale*/) override {
    resumed.push_back(frame);
  }
  void frame_written(const RigFrameResult& frame) override { written.push_back(frame.name); }
};

class RigSequence : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test::fresh_process_dir(
        "omnipoint_rig_sequence_" +
        std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::copy(rendered_path() / "frames", dir_ / "frames", fs::copy_options::recursive);
    options_.rig = (rendered_path() / "rig.json").string();
    options_.frames_dir = (dir_ / "frames").string();
    options_.output_files = {"points.npy"};
    options_.sequence = true;
    options_.predictor = oracle(&calls_);
  }
  // Without the sweeps: every frame's rig scale is the network's.
  void drop_sweeps(int64_t from = 0) {
    for (int64_t k = from; k < kFrames; ++k)
      fs::remove(dir_ / "frames" / frame_name(k) / "lidar.bin");
  }
  RigPredictJobSummary run(ScaleMode mode, const std::string& out, Counter* counter = nullptr) {
    RigPredictJobOptions options = options_;
    options.scale = mode;
    options.output_dir = (dir_ / out).string();
    return RigPredictJob(options, counter).Run();
  }
  json report(const std::string& out, int64_t k) const {
    return json::parse(test::slurp(dir_ / out / frame_name(k) / "rig.json"));
  }
  fs::path dir_;
  RigPredictJobOptions options_;
  int calls_ = 0;
};

// The mean |log| change of the applied rig scale between consecutive frames.
double mean_jump(const std::vector<double>& scales) {
  double sum = 0;
  for (size_t k = 1; k < scales.size(); ++k) sum += std::abs(std::log(scales[k] / scales[k - 1]));
  return sum / static_cast<double>(scales.size() - 1);
}

TEST_F(RigSequence, SmoothFixedAndPerFrameRigScales) {
  drop_sweeps();
  std::map<ScaleMode, std::vector<double>> applied;
  for (const ScaleMode mode : {ScaleMode::kPerFrame, ScaleMode::kSmooth, ScaleMode::kFixed}) {
    const std::string out = scale_mode_name(mode);
    SCOPED_TRACE(out);
    ASSERT_EQ(run(mode, out).written, kFrames);
    SequenceScale expected(mode, frame_factor(frame_name(0)) * 1.125);
    for (int64_t k = 0; k < kFrames; ++k) {
      const json r = report(out, k);
      const json& sequence = r.at("sequence");
      // The frame's own rig scale: the median of its two cameras' network scales.
      const double own = frame_factor(frame_name(k)) * 1.125;
      EXPECT_NEAR(sequence["frame_rig_scale"].get<double>(), own, 1e-9);
      EXPECT_EQ(sequence["scale_mode"], out);
      EXPECT_EQ(sequence["frame_index"], k);
      EXPECT_EQ(sequence["frames"], kFrames);
      const double rig_scale = r["rig_scale"].get<double>();
      EXPECT_DOUBLE_EQ(sequence["rig_scale"].get<double>(), rig_scale);
      EXPECT_NEAR(rig_scale, expected.next(own), 1e-9);  // the one rule, scale_smoother.h
      applied[mode].push_back(rig_scale);
      for (const auto& [name, unused] : mounts()) {
        SCOPED_TRACE(name);
        const json& camera = r["cameras"][name];
        EXPECT_EQ(camera["scale_source"], "network");
        // The cameras keep their factor relative to the rig scale.
        EXPECT_NEAR(camera["disagreement"].get<double>(), camera_factor(name) / 1.125 - 1, 1e-9);
        EXPECT_NEAR(camera["scale"].get<double>(),
                    rig_scale * (1 + camera["disagreement"].get<double>()), 1e-9);
        // The outputs at the applied rig scale: the truth times applied / 1 (the truth's scale).
        const fs::path truth = rendered_path() / "truth" / frame_name(k) / name;
        const data::Sample sample = data::read_sample(truth.string());
        const at::Tensor rays = io::read_npy((truth / "rays.npy").string());
        const at::Tensor points =
            io::read_npy((dir_ / out / frame_name(k) / name / "points.npy").string());
        EXPECT_TRUE(
            at::allclose(points, rig_scale * rays * sample.distance.unsqueeze(-1), 1e-5, 1e-6));
      }
    }
  }
  const double per_frame = mean_jump(applied[ScaleMode::kPerFrame]);
  const double smooth = mean_jump(applied[ScaleMode::kSmooth]);
  EXPECT_GT(per_frame, 0.2);
  EXPECT_LT(smooth, 0.5 * per_frame);
  EXPECT_EQ(mean_jump(applied[ScaleMode::kFixed]), 0.0);
  EXPECT_NEAR(applied[ScaleMode::kFixed].front(), 1.125, 1e-9);  // the first frame's
  std::printf("mean |log| frame-to-frame change of the rig scale: per-frame %.4f, smooth %.4f\n",
              per_frame, smooth);
}

// eval --sequence on a rig's video, per camera: a rig scale that jumps by k between frames
// gives |k - 1| for every camera (closed form: the outputs are the truth times the applied
// scale); fixed gives ~0, smooth less than per-frame. The truth at one scale (fixed) scores 0.004
// to 0.006 on these 80x60 views, the measure's own floor here, hence the 0.01.
TEST_F(RigSequence, TemporalStabilityPerCamera) {
  drop_sweeps();
  std::map<ScaleMode, double> scores;
  for (const ScaleMode mode : {ScaleMode::kPerFrame, ScaleMode::kSmooth, ScaleMode::kFixed}) {
    const std::string out = scale_mode_name(mode);
    SCOPED_TRACE(out);
    ASSERT_EQ(run(mode, out).written, kFrames);
    std::vector<double> applied;
    for (int64_t k = 0; k < kFrames; ++k)
      applied.push_back(report(out, k)["rig_scale"].get<double>());
    double expected = 0;
    for (size_t k = 1; k < applied.size(); ++k)
      expected += std::abs(applied[k] / applied[k - 1] - 1) / (kFrames - 1);
    const eval::RigTemporalStability stability =
        eval::score_predicted_rig_sequence((dir_ / out).string(), rendered_path().string());
    ASSERT_EQ(stability.cameras.size(), 2u);
    for (const auto& [name, camera] : stability.cameras) {
      SCOPED_TRACE(name);
      ASSERT_EQ(camera.pairs.size(), static_cast<size_t>(kFrames - 1));
      EXPECT_NEAR(camera.error, expected, 0.01);
    }
    scores[mode] = stability.error;
    std::printf("%s: temporal stability %.4f (front %.4f, back %.4f)\n", out.c_str(),
                stability.error, stability.cameras[1].second.error,
                stability.cameras[0].second.error);
  }
  EXPECT_LT(scores[ScaleMode::kFixed], 0.01);
  EXPECT_LT(scores[ScaleMode::kSmooth], scores[ScaleMode::kPerFrame]);
  // A camera's predictions missing: one error naming the file.
  fs::remove(dir_ / "smooth" / frame_name(2) / "front" / "points.npy");
  test::expect_error<std::invalid_argument>(
      [&] {
        eval::score_predicted_rig_sequence((dir_ / "smooth").string(), rendered_path().string());
      },
      {"points.npy", "no predicted points"});
}

// Frames 0..2 without their sweeps, 3..5 with: the LiDAR-aligned cameras keep their measured
// scale (the truth's: the network's scale times the alignment is 1), the frames without follow
// the running estimate, which the measured frames feed.
TEST_F(RigSequence, LidarAlignedCamerasKeepTheirMeasuredScales) {
  for (int64_t k = 0; k < 3; ++k) fs::remove(dir_ / "frames" / frame_name(k) / "lidar.bin");
  ASSERT_EQ(run(ScaleMode::kSmooth, "out").written, kFrames);
  SequenceScale expected(ScaleMode::kSmooth);
  for (int64_t k = 0; k < kFrames; ++k) {
    SCOPED_TRACE(k);
    const json r = report("out", k);
    const double own = r["sequence"]["frame_rig_scale"].get<double>();
    const double applied = expected.next(own);
    if (k < 3) {
      EXPECT_NEAR(r["rig_scale"].get<double>(), applied, 1e-9);
      continue;
    }
    EXPECT_DOUBLE_EQ(r["rig_scale"].get<double>(), own);  // measured: not smoothed
    EXPECT_NE(applied, own);
    EXPECT_NEAR(own, 1.0, 0.02);
    for (const auto& [name, unused] : mounts()) {
      const json& camera = r["cameras"][name];
      EXPECT_EQ(camera["scale_source"], "lidar") << name;
      EXPECT_NEAR(camera["scale"].get<double>(), 1.0, 0.02) << name;
      EXPECT_DOUBLE_EQ(camera["applied_scale"].get<double>(), camera["scale"].get<double>());
    }
  }
}

// Every file under `dir`, by its path below it (camera.json without its timings, which no two
// runs share).
std::map<std::string, std::string> contents(const fs::path& dir) {
  std::map<std::string, std::string> files;
  for (const fs::directory_entry& entry : fs::recursive_directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    std::string text = test::slurp(entry.path());
    if (entry.path().filename() == "camera.json") {
      json record = json::parse(text);
      EXPECT_EQ(record.erase("timing_ms"), 1u);
      text = record.dump();
    }
    files[fs::relative(entry.path(), dir).string()] = text;
  }
  return files;
}

TEST_F(RigSequence, AnInterruptedRunResumesAsIfUninterrupted) {
  drop_sweeps(4);  // measured frames and smoothed ones both in the replay
  ASSERT_EQ(run(ScaleMode::kSmooth, "whole").written, kFrames);
  EXPECT_EQ(calls_, 2 * kFrames);
  ASSERT_EQ(run(ScaleMode::kSmooth, "resumed").written, kFrames);
  // Interrupted: the last two frames never written (the third-last's folder half-staged).
  for (int64_t k = kFrames - 2; k < kFrames; ++k) fs::remove_all(dir_ / "resumed" / frame_name(k));
  fs::create_directories(dir_ / "resumed" / ("." + frame_name(kFrames - 2) + ".partial-abc123"));
  calls_ = 0;
  Counter counter;
  const RigPredictJobSummary summary = run(ScaleMode::kSmooth, "resumed", &counter);
  EXPECT_EQ(summary.resumed, kFrames - 2);
  EXPECT_EQ(summary.written, 2);
  EXPECT_EQ(calls_, 2 * 2);  // the finished frames are not predicted again
  EXPECT_EQ(counter.written, (std::vector<std::string>{frame_name(4), frame_name(5)}));
  EXPECT_EQ(counter.resumed.size(), static_cast<size_t>(kFrames - 2));
  EXPECT_EQ(contents(dir_ / "resumed"), contents(dir_ / "whole"));

  // Another --scale into the same OUT: one error before any frame, nothing changed.
  calls_ = 0;
  test::expect_error<std::invalid_argument>([&] { run(ScaleMode::kPerFrame, "resumed"); },
                                            {"--scale smooth", "--out"});
  EXPECT_EQ(calls_, 0);
  EXPECT_EQ(contents(dir_ / "resumed"), contents(dir_ / "whole"));
}

// Without sequence nothing of it: no sequence record, each frame at its own rig scale, every
// frame predicted again into an OUT that holds them.
TEST_F(RigSequence, WithoutSequenceEveryFrameStandsAlone) {
  drop_sweeps();
  options_.sequence = false;
  ASSERT_EQ(run(ScaleMode::kSmooth, "out").written, kFrames);
  ASSERT_EQ(run(ScaleMode::kSmooth, "out").written, kFrames);
  EXPECT_EQ(calls_, 4 * kFrames);  // two runs of two predictions per frame
  for (int64_t k = 0; k < kFrames; ++k) {
    const json r = report("out", k);
    EXPECT_FALSE(r.contains("sequence"));
    EXPECT_NEAR(r["rig_scale"].get<double>(), frame_factor(frame_name(k)) * 1.125, 1e-9);
  }
}

// synth --rig --path: the body moves along the camera path (camera_path.h) through the one
// scene of the seed: frame k's body stands k * step metres along the viewpoint's level viewing
// direction, turned k * yaw about the vertical; closed form for frames 0 and 4.
TEST(SynthRigPath, BodyPosesFollowThePath) {
  const data::synth::Scene scene = data::synth::make_scene(data::synth::SceneKind::kIndoor, kSeed);
  const at::Tensor start = data::synth::world_from_body(scene, data::synth::BodyAxes::kCamera, 0);
  const double heading = std::atan2(scene.pose.rotation[1][2], scene.pose.rotation[0][2]);
  for (const int64_t k : {int64_t{0}, int64_t{4}}) {
    at::Tensor expected = start.clone();
    const double turn = k * kYawDeg * M_PI / 180;
    const at::Tensor rz = at::tensor({std::cos(turn), -std::sin(turn), 0.0, std::sin(turn),
                                      std::cos(turn), 0.0, 0.0, 0.0, 1.0},
                                     at::kDouble)
                              .view({3, 3});
    expected.slice(0, 0, 3).slice(1, 0, 3).copy_(rz.matmul(start.slice(0, 0, 3).slice(1, 0, 3)));
    expected[0][3] += k * kStep * std::cos(heading);
    expected[1][3] += k * kStep * std::sin(heading);
    for (const auto& [name, body_from_camera] : mounts()) {
      SCOPED_TRACE(name + " frame " + std::to_string(k));
      const json meta =
          json::parse(test::slurp(rendered_path() / "truth" / frame_name(k) / name / "meta.json"));
      at::Tensor world_from_camera = at::eye(4, at::kDouble);
      for (int r = 0; r < 3; ++r) {
        for (int c = 0; c < 3; ++c)
          world_from_camera[r][c] = meta["pose"]["rotation"][r][c].get<double>();
        world_from_camera[r][3] = meta["pose"]["position"][r].get<double>();
      }
      const at::Tensor body = world_from_camera.matmul(at::linalg_inv(body_from_camera));
      EXPECT_TRUE(at::allclose(body, expected, 1e-9, 1e-9)) << body << "\n" << expected;
    }
    EXPECT_TRUE(fs::is_regular_file(rendered_path() / "frames" / frame_name(k) / "lidar.bin"));
  }
  // One scene: the frames' meta.json name the same seed.
  const json first =
      json::parse(test::slurp(rendered_path() / "truth" / frame_name(0) / "front" / "meta.json"));
  const json last = json::parse(
      test::slurp(rendered_path() / "truth" / frame_name(kFrames - 1) / "front" / "meta.json"));
  EXPECT_EQ(first["seed"], last["seed"]);
  // A step no path takes: one error.
  data::synth::RigFramesOptions options;
  options.rig = (rendered_path() / "rig.json").string();
  options.path = true;
  options.path_step = 50;
  test::expect_error<std::invalid_argument>([&] { options.Check(); }, {"--path-step"});
}

// The command line with the tiny model: a rig sequence written, then resumed; conflicting
// options give one error line and write nothing.
TEST(RigSequenceCli, WritesResumesAndRefusesConflicts) {
  const fs::path dir = test::fresh_process_dir("omnipoint_rig_sequence_cli");
  const std::string model = " --model '" + tiny_model_path() + "' --num-tokens 12";
  const std::string base = "predict --rig " + (rendered_path() / "rig.json").string() + " " +
                           (rendered_path() / "frames").string() + " --sequence";
  const std::string out = " --out " + (dir / "out").string();
  const test::CliRun run = test::run_omnipoint(base + out + model + " --outputs ply", dir);
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find(std::to_string(kFrames) + " frame(s): " + std::to_string(kFrames) +
                         " written, 0 failed"),
            std::string::npos)
      << run.err;
  const json r = json::parse(test::slurp(dir / "out" / frame_name(1) / "rig.json"));
  EXPECT_EQ(r["sequence"]["scale_mode"], "smooth");
  const test::CliRun again = test::run_omnipoint(base + out + model + " --outputs ply", dir);
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_NE(again.err.find("0 written, " + std::to_string(kFrames) + " resumed"), std::string::npos)
      << again.err;

  const auto one_error = [&](const std::string& args, const std::string& part) {
    const test::CliRun bad = test::run_omnipoint(args + model, dir);
    EXPECT_NE(bad.status, 0);
    std::istringstream lines(bad.err);
    int errors = 0;
    for (std::string line; std::getline(lines, line);)
      if (line.find("error") != std::string::npos) ++errors;
    EXPECT_EQ(errors, 1) << bad.err;
    EXPECT_NE(bad.err.find(part), std::string::npos) << bad.err;
  };
  const std::string other = " --out " + (dir / "other").string();
  one_error(base + " --calibration-frames 4" + other, "--calibration-frames");
  one_error(base + " --camera 'PINHOLE 80 60 64 64 40 30'" + other, "--camera");
  one_error(base + " --scale median" + other, "--scale");
  one_error(base + " --scale per-frame" + out, "--scale smooth");  // OUT of another mode
  EXPECT_FALSE(fs::exists(dir / "other"));
}

}  // namespace
}  // namespace omnipoint::predict
