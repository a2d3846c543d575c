// `predict --sequence` (predict/sequence_predict_job.h) on a rendered camera path with the
// bundled model: the smoothed scale is steadier than per-frame prediction (temporal stability,
// eval/temporal.h), the calibrated camera equals the single-frame fits on average, an
// interrupted run resumes without redoing finished frames and continues the running scale
// exactly; the running scale's rules in closed form; bad inputs one line each, nothing written.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "omnipoint/camera/camera_info.h"
#include "omnipoint/camera/fit.h"
#include "omnipoint/data/synth/camera_path.h"
#include "omnipoint/eval/temporal.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/predict/sequence_predict_job.h"
#include "support/scratch_dir.h"

namespace omnipoint::predict {
namespace {

namespace fs = std::filesystem;

std::string bundled_model() {
  return std::string(OMNIPOINT_SOURCE_DIR) + "/models/omnipoint_default.safetensors";
}

// Closed-form rules of the running scale.
TEST(SequenceScale, PerFrameAndFixed) {
  SequenceScale per_frame(ScaleMode::kPerFrame);
  SequenceScale fixed(ScaleMode::kFixed, 2.5);
  for (const double s : {1.0, 3.0, 0.5}) {
    EXPECT_DOUBLE_EQ(per_frame.next(s), s);
    EXPECT_DOUBLE_EQ(fixed.next(s), 2.5);
  }
  EXPECT_THROW(per_frame.next(0), std::invalid_argument);
  EXPECT_THROW(per_frame.next(std::nan("")), std::invalid_argument);
  EXPECT_THROW(SequenceScale(ScaleMode::kFixed, -1), std::invalid_argument);
}

TEST(SequenceScale, SmoothFollowsItsDefinition) {
  SequenceScale smooth(ScaleMode::kSmooth);
  EXPECT_DOUBLE_EQ(smooth.next(2.0), 2.0);  // m_0 = x_0
  EXPECT_NEAR(smooth.next(2.0), 2.0, 1e-12);
  // An outlier x 3 is clipped to the window's median + kSmoothClip and moves the estimate by
  // kSmoothGain of that.
  const double expected =
      std::exp(std::log(2.0) + SequenceScale::kSmoothGain * SequenceScale::kSmoothClip);
  EXPECT_NEAR(smooth.next(6.0), expected, 1e-12);
  // A small step is followed by kSmoothGain of it per frame (no clipping within the band).
  SequenceScale step(ScaleMode::kSmooth);
  step.next(1.0);
  EXPECT_NEAR(std::log(step.next(1.1)), SequenceScale::kSmoothGain * std::log(1.1), 1e-12);
  // A lasting change is followed: after a window of frames at x 2 the estimate is close to it.
  SequenceScale lasting(ScaleMode::kSmooth);
  lasting.next(1.0);
  double last = 0;
  for (int i = 0; i < 30; ++i) last = lasting.next(2.0);
  EXPECT_NEAR(last, 2.0, 0.02);
  // The state is a function of the scales fed: a replay gives the same values.
  SequenceScale a(ScaleMode::kSmooth), b(ScaleMode::kSmooth);
  for (const double s : {1.0, 1.3, 0.7, 2.0, 1.1, 0.95, 1.05}) EXPECT_EQ(a.next(s), b.next(s));
}

TEST(SequenceScale, ModeNames) {
  for (const ScaleMode mode : {ScaleMode::kFixed, ScaleMode::kSmooth, ScaleMode::kPerFrame})
    EXPECT_EQ(parse_scale_mode(scale_mode_name(mode)), mode);
  EXPECT_THROW(parse_scale_mode("median"), std::invalid_argument);
}

// What the job reported, by frame index.
struct Recorder : SequencePredictJobObserver {
  std::set<size_t> resumed, written, failed;
  std::vector<std::string> notes;
  void note(const std::string& text) override { notes.push_back(text); }
  void frame_resumed(size_t index, const ImageEntry&, double) override { resumed.insert(index); }
  void frame_written(size_t index, const ImageEntry&, const PredictedImage&, double) override {
    written.insert(index);
  }
  void frame_failed(size_t index, const ImageEntry&, const std::string&) override {
    failed.insert(index);
  }
};

nlohmann::json sequence_record(const fs::path& frame) {
  return nlohmann::json::parse(io::read_file((frame / "camera.json").string())).at("sequence");
}

// One rendered path and the runs on it, shared by the tests below.
class SequencePredict : public ::testing::Test {
 protected:
  static constexpr int64_t kFrames = 6;
  static constexpr int64_t kCalibrationFrames = 4;

  static void SetUpTestSuite() {
    // One folder per process: CTest runs each test of the suite in a process of its own, at
    // the same time as the others.
    dir_ = test::fresh_process_dir("omnipoint_sequence_predict");
    data::synth::CameraPathOptions path;
    path.camera = camera::Camera("PINHOLE", 96, 72, {60, 60, 48, 36});
    path.frames = kFrames;
    path.step = 0.08;
    path.yaw_step_deg = 1.5;
    path.synth.render.ambient_occlusion = false;
    data::synth::write_camera_path((dir_ / "path").string(), path);
    smooth_ = run(ScaleMode::kSmooth, "smooth", "", &smooth_report_);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static SequencePredictJobOptions options(ScaleMode mode, const std::string& out,
                                           const std::string& camera) {
    SequencePredictJobOptions options;
    options.frames_dir = (dir_ / "path" / "frames").string();
    options.camera = camera;
    options.calibration_frames = kCalibrationFrames;
    options.scale = mode;
    options.model_path = bundled_model();
    options.output_dir = (dir_ / out).string();
    options.output_files = {"points.npy", "mask.png"};
    return options;
  }
  static SequencePredictJobSummary run(ScaleMode mode, const std::string& out,
                                       const std::string& camera, Recorder* recorder) {
    return SequencePredictJob(options(mode, out, camera), recorder).Run();
  }
  static double stability(const std::string& out) {
    return eval::score_predicted_sequence((dir_ / out).string(), (dir_ / "path").string()).error;
  }

  static fs::path dir_;
  static SequencePredictJobSummary smooth_;
  static Recorder smooth_report_;
};
fs::path SequencePredict::dir_;
SequencePredictJobSummary SequencePredict::smooth_;
Recorder SequencePredict::smooth_report_;

TEST_F(SequencePredict, WritesEveryFrameWithItsScales) {
  EXPECT_EQ(smooth_.frames, kFrames);
  EXPECT_EQ(smooth_.written, kFrames);
  EXPECT_EQ(smooth_.failed, 0);
  EXPECT_EQ(smooth_report_.written.size(), static_cast<size_t>(kFrames));
  const camera::Camera calibrated = io::read_camera(smooth_.camera);
  for (int64_t i = 0; i < kFrames; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%06lld", static_cast<long long>(i));
    const fs::path frame = dir_ / "smooth" / name;
    ASSERT_TRUE(fs::is_regular_file(frame / "points.npy")) << frame;
    const nlohmann::json json =
        nlohmann::json::parse(io::read_file((frame / "camera.json").string()));
    const nlohmann::json& record = json.at("sequence");
    EXPECT_EQ(record.at("scale_mode"), "smooth");
    EXPECT_EQ(record.at("frame_index"), i);
    EXPECT_EQ(record.at("metric_scale").get<double>(), json.at("metric_scale").get<double>());
    EXPECT_GT(record.at("network_metric_scale").get<double>(), 0);
    EXPECT_NE(record.at("camera").get<std::string>().find("calibrated from 4 frames"),
              std::string::npos);
    EXPECT_EQ(json.at("camera_source"), "given");
    EXPECT_EQ(json.at("camera_spec"), calibrated.to_spec());
  }
}

// The figure: --scale smooth is steadier than per-frame prediction (same camera).
TEST_F(SequencePredict, SmoothIsSteadierThanPerFrame) {
  Recorder report;
  run(ScaleMode::kPerFrame, "per_frame", smooth_.camera, &report);
  const double smooth = stability("smooth"), per_frame = stability("per_frame");
  std::printf("temporal stability: smooth %.5f, per-frame %.5f\n", smooth, per_frame);
  EXPECT_LT(smooth, per_frame);
}

TEST_F(SequencePredict, FixedAppliesOneScale) {
  Recorder report;
  const SequencePredictJobSummary fixed = run(ScaleMode::kFixed, "fixed", smooth_.camera, &report);
  // The median of the first frames' network scales with the same camera: the smooth run's.
  std::vector<double> first;
  for (const char* name : {"000000", "000001", "000002", "000003"})
    first.push_back(sequence_record(dir_ / "smooth" / name).at("network_metric_scale"));
  std::sort(first.begin(), first.end());
  EXPECT_NEAR(fixed.fixed_scale, (first[1] + first[2]) / 2, 1e-6 * fixed.fixed_scale);
  for (const auto& entry : fs::directory_iterator(dir_ / "fixed"))
    EXPECT_DOUBLE_EQ(sequence_record(entry.path()).at("metric_scale").get<double>(),
                     fixed.fixed_scale);
  std::printf("temporal stability: fixed %.5f\n", stability("fixed"));
}

// The calibrated camera equals the single-frame automatic fits of its frames on average: the
// model most of them chose, and rays within kToleranceDeg of each fit's rays (the mean angle over
// the pixels both cover, averaged over the frames); it explains each frame's predicted rays
// about as well as that frame's own fit does.
TEST_F(SequencePredict, CalibratedCameraMatchesSingleFrameFits) {
  const camera::Camera calibrated = io::read_camera(smooth_.camera);
  const Model model = Model::load(bundled_model());
  const camera::Rays calibrated_rays = calibrated.ray_map(at::kDouble);
  double ray_angle_sum = 0, own_residual_sum = 0, calibrated_residual_sum = 0;
  std::map<std::string, int> models;
  for (int64_t i = 0; i < kCalibrationFrames; ++i) {
    char name[32];
    std::snprintf(name, sizeof name, "%06lld.png", static_cast<long long>(i));
    const at::Tensor image = io::read_image((dir_ / "path" / "frames" / name).string());
    const Prediction p = model.predict(image);
    ASSERT_TRUE(p.fitted_camera && p.fit_residual);
    ++models[p.fitted_camera->model_name()];
    const camera::Rays fit_rays = p.fitted_camera->ray_map(at::kDouble);
    const at::Tensor both = fit_rays.valid & calibrated_rays.valid;
    const at::Tensor cosine = (fit_rays.rays * calibrated_rays.rays).sum(-1).clamp(-1, 1);
    const double angle = (at::acos(cosine.index({both})) * (180.0 / M_PI)).mean().item<double>();
    const double own = p.fit_residual->mean_deg;
    const double joint = camera::angular_residual(calibrated, p.rays, p.mask).mean_deg;
    std::printf(
        "frame %lld: fit %s hfov %.2f deg, its rays %.3f deg from the calibrated camera's;"
        " residual to the predicted rays: own fit %.3f deg, calibrated %.3f deg\n",
        static_cast<long long>(i), p.fitted_camera->model_name().c_str(),
        camera::field_of_view(*p.fitted_camera).horizontal_deg, angle, own, joint);
    ray_angle_sum += angle;
    own_residual_sum += own;
    calibrated_residual_sum += joint;
  }
  const double n = static_cast<double>(kCalibrationFrames);
  std::printf(
      "calibrated %s hfov %.2f deg: rays %.3f deg from the single-frame fits' on average; "
      "mean residual %.3f deg (own fits %.3f deg)\n",
      calibrated.model_name().c_str(), camera::field_of_view(calibrated).horizontal_deg,
      ray_angle_sum / n, calibrated_residual_sum / n, own_residual_sum / n);
  int most = 0;
  for (const auto& [name, count] : models) most = std::max(most, count);
  EXPECT_EQ(models[calibrated.model_name()], most);
  constexpr double kToleranceDeg = 2.0;
  EXPECT_LT(ray_angle_sum / n, kToleranceDeg);
  EXPECT_LT(calibrated_residual_sum / n, own_residual_sum / n + 0.5);
}

// An interrupted run (its last frames' folders gone) resumes: the finished frames are reported
// resumed and left alone (same inodes and times), the rest are predicted with the running scale
// continued exactly, and the camera is read back rather than calibrated again.
TEST_F(SequencePredict, ResumesWithoutRedoingFinishedFrames) {
  fs::copy(dir_ / "smooth", dir_ / "resumed", fs::copy_options::recursive);
  constexpr int64_t kKept = 4;
  std::map<std::string, std::pair<ino_t, int64_t>> stamps;  // file -> inode, mtime (ns)
  for (const auto& entry : fs::recursive_directory_iterator(dir_ / "resumed")) {
    if (!entry.is_regular_file()) continue;
    struct stat info {};
    ASSERT_EQ(::stat(entry.path().c_str(), &info), 0);
    stamps[entry.path().string()] = {info.st_ino,
                                     info.st_mtim.tv_sec * 1000000000LL + info.st_mtim.tv_nsec};
  }
  for (int64_t i = kKept; i < kFrames; ++i) {
    char name[16];
    std::snprintf(name, sizeof name, "%06lld", static_cast<long long>(i));
    for (const auto& [file, stamp] : std::map<std::string, std::pair<ino_t, int64_t>>(stamps))
      if (file.find(std::string("/") + name + "/") != std::string::npos) stamps.erase(file);
    fs::remove_all(dir_ / "resumed" / name);
  }
  Recorder report;
  const SequencePredictJobSummary resumed = run(ScaleMode::kSmooth, "resumed", "", &report);
  EXPECT_EQ(resumed.resumed, kKept);
  EXPECT_EQ(resumed.written, kFrames - kKept);
  EXPECT_EQ(report.resumed, (std::set<size_t>{0, 1, 2, 3}));
  EXPECT_EQ(report.written, (std::set<size_t>{4, 5}));
  EXPECT_EQ(resumed.camera, smooth_.camera);  // read back, not calibrated again
  for (const auto& [file, stamp] : stamps) {
    struct stat info {};
    ASSERT_EQ(::stat(file.c_str(), &info), 0) << file;
    EXPECT_EQ(info.st_ino, stamp.first) << file;
    EXPECT_EQ(info.st_mtim.tv_sec * 1000000000LL + info.st_mtim.tv_nsec, stamp.second) << file;
  }
  for (const char* name : {"000004", "000005"}) {
    const double original = sequence_record(dir_ / "smooth" / name).at("metric_scale");
    const double again = sequence_record(dir_ / "resumed" / name).at("metric_scale");
    EXPECT_NEAR(again, original, 1e-6 * original) << name;
  }
  // Another --scale cannot continue these frames: an error before anything is written.
  EXPECT_THROW(run(ScaleMode::kPerFrame, "resumed", "", &report), std::invalid_argument);
}

TEST(SequencePredictOptions, BadInputsAreErrorsBeforeAnyWork) {
  const fs::path dir = fs::temp_directory_path() / "omnipoint_sequence_bad";
  fs::remove_all(dir);
  fs::create_directories(dir / "empty");
  SequencePredictJobOptions options;
  options.model_path = bundled_model();
  options.output_dir = (dir / "out").string();
  options.frames_dir = (dir / "missing").string();
  EXPECT_THROW(SequencePredictJob(options).Run(), std::invalid_argument);
  options.frames_dir = (dir / "empty").string();
  EXPECT_THROW(SequencePredictJob(options).Run(), std::invalid_argument);
  options.calibration_frames = 0;
  EXPECT_THROW(options.Check(), std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir / "out"));
  fs::remove_all(dir);
}

struct CliRun {
  int status;
  std::string err;
};

CliRun run_cli(const fs::path& dir, const std::string& args) {
  const fs::path err = dir / "stderr.txt";
  const std::string command = "cd '" + dir.string() + "' && '" + std::string(OMNIPOINT_CLI) + "' " +
                              args + " > /dev/null 2> '" + err.string() + "'";
  const int status = std::system(command.c_str());
  std::ifstream in(err);
  std::stringstream text;
  text << in.rdbuf();
  return {status, text.str()};
}

int error_lines(const std::string& err) {
  int count = 0;
  std::istringstream lines(err);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind("omnipoint: error: ", 0) == 0) ++count;
  return count;
}

// The command: each bad input one error line, a non-zero exit, no --out written.
TEST(SequencePredictCli, BadInputsOneLineEach) {
  const fs::path dir = fs::temp_directory_path() / "omnipoint_sequence_cli";
  fs::remove_all(dir);
  fs::create_directories(dir / "empty");
  fs::create_directories(dir / "frames");
  io::write_image_png((dir / "frames" / "a.png").string(), at::zeros({8, 8, 3}, at::kByte));
  for (const std::string& args :
       {std::string("predict --sequence missing --out out"),
        std::string("predict --sequence empty --out out"),
        std::string("predict --sequence frames --calibration-frames 0 --out out"),
        std::string("predict --sequence frames --rig rig.json --out out"),
        std::string("predict --sequence frames --scale median --out out"),
        std::string("predict --scale fixed frames --out out")}) {
    const CliRun run = run_cli(dir, args);
    EXPECT_NE(run.status, 0) << args;
    EXPECT_EQ(error_lines(run.err), 1) << args << "\n" << run.err;
    EXPECT_FALSE(fs::exists(dir / "out")) << args;
  }
  fs::remove_all(dir);
}

// The three commands end to end: synth --path, predict --sequence (and its resume), eval
// --sequence with --out.
TEST(SequencePredictCli, SynthPredictResumeEval) {
  const fs::path dir = fs::temp_directory_path() / "omnipoint_sequence_cli_run";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const CliRun synth = run_cli(
      dir, "synth --path --count 3 --camera 'PINHOLE 48 36 30 30 24 18' --no-ao --out walk");
  ASSERT_EQ(synth.status, 0) << synth.err;
  const CliRun first = run_cli(dir,
                               "predict --sequence walk/frames --calibration-frames 2 --outputs "
                               "npy,mask --out pred --model " +
                                   bundled_model());
  ASSERT_EQ(first.status, 0) << first.err;
  EXPECT_NE(first.err.find("camera calibrated from 2 frames"), std::string::npos) << first.err;
  for (const char* name : {"000000", "000001", "000002"})
    EXPECT_EQ(sequence_record(dir / "pred" / name).at("scale_mode"), "smooth") << name;
  fs::remove_all(dir / "pred" / "000002");
  const CliRun again = run_cli(dir,
                               "predict --sequence walk/frames --calibration-frames 2 --outputs "
                               "npy,mask --out pred --model " +
                                   bundled_model());
  ASSERT_EQ(again.status, 0) << again.err;
  EXPECT_NE(again.err.find("2 of 3 frame(s) finished by an earlier run"), std::string::npos)
      << again.err;
  EXPECT_NE(again.err.find("1 written, 2 resumed"), std::string::npos) << again.err;
  const CliRun eval = run_cli(dir, "eval --sequence pred --truth walk --out scores");
  ASSERT_EQ(eval.status, 0) << eval.err;
  const nlohmann::json scores =
      nlohmann::json::parse(io::read_file((dir / "scores" / "temporal.json").string()));
  EXPECT_EQ(scores.at("pairs").size(), 2u);
  EXPECT_GE(scores.at("temporal_stability").get<double>(), 0);
  const CliRun no_truth = run_cli(dir, "eval --sequence pred");
  EXPECT_NE(no_truth.status, 0);
  EXPECT_EQ(error_lines(no_truth.err), 1) << no_truth.err;
  fs::remove_all(dir);
}

}  // namespace
}  // namespace omnipoint::predict
