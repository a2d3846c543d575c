// omnipoint predict end to end: outputs per image, and each kind of bad input -> one line on
// stderr naming it, a non-zero exit, and no folder for the skipped image.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "omnipoint/camera/camera.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/predict/predictor.h"
#include "predict/tiny_model.h"

namespace omnipoint::predict {
namespace {

namespace fs = std::filesystem;

struct CliRun {
  int status;
  std::string err;
};

// Runs the CLI in `dir` with stderr captured; `environment`: "NAME=value " assignments.
CliRun run_cli(const fs::path& dir, const std::string& args, const std::string& environment = "") {
  const fs::path err = dir / "stderr.txt";
  const std::string command = "cd '" + dir.string() + "' && " + environment + "'" +
                              std::string(OMNIPOINT_CLI) + "' " + args + " > /dev/null 2> '" +
                              err.string() + "'";
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

class PredictCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("omnipoint_predict_cli_" +
            std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    io::write_image_png((dir_ / "good.png").string(), at::rand({30, 40, 3}));
    model_ = " --model '" + tiny_model_path() + "' --num-tokens 12 --out out";
  }
  fs::path dir_;
  std::string model_;
};

TEST_F(PredictCli, WritesEveryOutput) {
  io::write_image_png((dir_ / "grey16.png").string(), at::randint(0, 65535, {30, 40}, at::kInt));
  const CliRun run =
      run_cli(dir_, "predict good.png grey16.png --camera 'PINHOLE 40 30 35 35 20 15'" + model_);
  ASSERT_EQ(run.status, 0) << run.err;
  for (const std::string name : {"good", "grey16"})
    for (const std::string file :
         {"points.ply", "points.glb", "points.npy", "distance.npy", "depth.npy", "rays.npy",
          "mask.png", "depth.png", "depth_vis.png", "preview.png", "image.png", "camera.json"})
      EXPECT_TRUE(fs::is_regular_file(dir_ / "out" / name / file)) << name << "/" << file;
  EXPECT_NE(run.err.find("[2/2]"), std::string::npos) << run.err;  // progress for several images
}

TEST_F(PredictCli, MissingModelSaysSo) {
  const CliRun run =
      run_cli(dir_, "predict good.png", "OMNIPOINT_MODEL=no_such_model.safetensors ");
  EXPECT_NE(run.status, 0);
  EXPECT_EQ(error_lines(run.err), 1) << run.err;
  EXPECT_NE(run.err.find("no_such_model.safetensors"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir_ / "predictions"));
}

// Without --model the bundled model predicts, from any working folder.
TEST_F(PredictCli, BundledModelIsTheDefault) {
  const CliRun run = run_cli(dir_, "predict good.png --out bundled", "env -u OMNIPOINT_MODEL ");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_TRUE(fs::is_regular_file(dir_ / "bundled" / "good" / "points.ply"));
  EXPECT_TRUE(fs::is_regular_file(dir_ / "bundled" / "good" / "camera.json"));
}

// Once, before the images: the bundled model is a demonstration, and the command for a real one.
TEST_F(PredictCli, TheBundledModelSaysOnceWhatItLearnedFrom) {
  io::write_image_png((dir_ / "second.png").string(), at::rand({30, 40, 3}));
  const CliRun bundled =
      run_cli(dir_, "predict good.png second.png --out bundled", "env -u OMNIPOINT_MODEL ");
  ASSERT_EQ(bundled.status, 0) << bundled.err;
  const std::string note = "omnipoint: note: the bundled model learned from synthetic scenes only";
  ASSERT_EQ(bundled.err.rfind(note, 0), 0u) << bundled.err;
  EXPECT_EQ(bundled.err.find(note, 1), std::string::npos) << bundled.err;
  EXPECT_NE(bundled.err.find("omnipoint models pull moge-2-vitl-normal"), std::string::npos)
      << bundled.err;
  // A model chosen (--model, or $OMNIPOINT_MODEL) gets no such note.
  const CliRun chosen = run_cli(dir_, "predict good.png" + model_);
  ASSERT_EQ(chosen.status, 0) << chosen.err;
  EXPECT_EQ(chosen.err.find("bundled model"), std::string::npos) << chosen.err;
  const CliRun from_environment = run_cli(dir_, "predict good.png --num-tokens 12 --out env",
                                          "OMNIPOINT_MODEL='" + tiny_model_path() + "' ");
  ASSERT_EQ(from_environment.status, 0) << from_environment.err;
  EXPECT_EQ(from_environment.err.find("bundled model"), std::string::npos) << from_environment.err;
}

TEST_F(PredictCli, CorruptImageIsSkipped) {
  std::ofstream((dir_ / "corrupt.png").string()) << "not a png";
  const CliRun run = run_cli(dir_, "predict corrupt.png good.png" + model_);
  EXPECT_NE(run.status, 0);
  EXPECT_NE(run.err.find("corrupt.png"), std::string::npos) << run.err;
  EXPECT_EQ(error_lines(run.err), 2) << run.err;  // the skipped image, then the summary
  EXPECT_FALSE(fs::exists(dir_ / "out" / "corrupt"));
  EXPECT_TRUE(fs::is_regular_file(dir_ / "out" / "good" / "camera.json"));
}

TEST_F(PredictCli, BadSparseDepthIsSkipped) {
  io::write_npy((dir_ / "small.npy").string(), at::ones({10, 10}));
  std::ofstream((dir_ / "bad.ply").string())
      << "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nend_header\n";
  for (const std::string sparse : {"small.npy", "bad.ply"}) {
    const CliRun run =
        run_cli(dir_, "predict good.png --camera 'PINHOLE 40 30 35 35 20 15' --sparse-depth " +
                          sparse + model_);
    EXPECT_NE(run.status, 0) << sparse;
    EXPECT_NE(run.err.find(sparse == "small.npy" ? "sparse depth" : "bad.ply"), std::string::npos)
        << run.err;
    EXPECT_EQ(error_lines(run.err), 2) << run.err;
    EXPECT_FALSE(fs::exists(dir_ / "out" / "good")) << sparse;
  }
}

int lines_starting(const std::string& err, const std::string& start) {
  int count = 0;
  std::istringstream lines(err);
  for (std::string line; std::getline(lines, line);)
    if (line.rfind(start, 0) == 0) ++count;
  return count;
}

// Folders are searched recursively for every image format; outputs mirror the tree; files that
// are not images are counted, not silently dropped.
TEST_F(PredictCli, FoldersAreSearchedRecursivelyAndMirrored) {
  fs::create_directories(dir_ / "shots" / "day" / "left");
  const at::Tensor image = (at::rand({30, 40, 3}) * 255).to(at::kByte);
  io::write_image_png((dir_ / "shots" / "a.png").string(), image);
  // WebP and TIFF through OpenCV's encoders (write_image_png writes PNG only).
  const cv::Mat bgr(30, 40, CV_8UC3, cv::Scalar(40, 120, 200));
  ASSERT_TRUE(cv::imwrite((dir_ / "shots" / "day" / "left" / "b.webp").string(), bgr));
  ASSERT_TRUE(cv::imwrite((dir_ / "shots" / "day" / "c.TIF").string(), bgr));
  std::ofstream((dir_ / "shots" / "notes.txt").string()) << "not an image";
  const CliRun run = run_cli(dir_, "predict shots" + model_);
  ASSERT_EQ(run.status, 0) << run.err;
  for (const std::string folder : {"a", "day/left/b", "day/c"})
    EXPECT_TRUE(fs::is_regular_file(dir_ / "out" / folder / "camera.json")) << folder;
  EXPECT_NE(run.err.find("1 file(s) in the input folders are not images"), std::string::npos)
      << run.err;
  EXPECT_NE(run.err.find("3 image(s): 3 written, 0 failed, 0 warning(s)"), std::string::npos)
      << run.err;
}

// Each silent mistake of the past is a warning line now, and the summary counts them.
TEST_F(PredictCli, SuspiciousSparseDepthIsAWarning) {
  fs::create_directories(dir_ / "frames");
  fs::create_directories(dir_ / "lidar");
  io::write_image_png((dir_ / "frames" / "with.png").string(), at::rand({30, 40, 3}));
  io::write_image_png((dir_ / "frames" / "without.png").string(), at::rand({30, 40, 3}));
  // A cloud of points all behind the camera: none lands in the image.
  const at::Tensor behind = at::cat({at::rand({100, 2}), -at::ones({100, 1})}, 1);
  io::write_ply((dir_ / "lidar" / "with.ply").string(), behind);
  const CliRun run = run_cli(
      dir_, "predict frames --camera 'PINHOLE 40 30 35 35 20 15' --sparse-depth lidar" + model_);
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find("without.png: no sparse depth file for it in lidar"), std::string::npos)
      << run.err;
  EXPECT_NE(run.err.find("is taken as in the camera frame (no --lidar-to-camera given)"),
            std::string::npos)
      << run.err;
  EXPECT_NE(run.err.find("only 0 of the point cloud's 100 points land in the image"),
            std::string::npos)
      << run.err;
  const int warnings = lines_starting(run.err, "omnipoint: warning: ");
  EXPECT_GE(warnings, 4) << run.err;  // + no sample where the prediction is valid
  EXPECT_NE(run.err.find("2 written, 0 failed, " + std::to_string(warnings) + " warning(s)"),
            std::string::npos)
      << run.err;
}

TEST_F(PredictCli, MaxSizeShrinksTheNetworkInputAndTheOutputs) {
  io::write_image_png((dir_ / "large.png").string(), at::rand({60, 80, 3}));
  const CliRun run = run_cli(
      dir_, "predict large.png --max-size 40 --camera 'PINHOLE 80 60 70 70 40 30'" + model_);
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find("at 40x30"), std::string::npos) << run.err;
  const at::Tensor mask = io::read_image_values((dir_ / "out" / "large" / "mask.png").string());
  EXPECT_EQ(mask.sizes(), (at::IntArrayRef{30, 40}));
  const at::Tensor rays = io::read_npy((dir_ / "out" / "large" / "rays.npy").string());
  // The given camera, halved: the centre pixel's ray is the axis, the corner's as at full size.
  const camera::Camera half = camera::parse_camera("PINHOLE 40 30 35 35 20 15");
  EXPECT_TRUE(at::allclose(rays, half.ray_map().rays, 1e-5, 1e-6));
}

TEST_F(PredictCli, FieldOfViewGivesAPinhole) {
  const CliRun run = run_cli(dir_, "predict good.png --fov 90" + model_);
  ASSERT_EQ(run.status, 0) << run.err;
  // 90 degrees across 40 pixels: f = 20 / tan(45 degrees) = 20.
  const at::Tensor rays = io::read_npy((dir_ / "out" / "good" / "rays.npy").string());
  const camera::Camera expected = camera::parse_camera("PINHOLE 40 30 20 20 20 15");
  EXPECT_TRUE(at::allclose(rays, expected.ray_map().rays, 1e-5, 1e-6));
  EXPECT_NE(run_cli(dir_, "predict good.png --fov 90 --camera 'PINHOLE 40 30 20 20 20 15'" + model_)
                .status,
            0);
}

TEST_F(PredictCli, CudaWithoutCudaIsOneLine) {
  if (at::hasCUDA()) GTEST_SKIP() << "this build has CUDA";
  const CliRun run = run_cli(dir_, "predict good.png --device cuda" + model_);
  EXPECT_NE(run.status, 0);
  EXPECT_EQ(error_lines(run.err), 1) << run.err;
  EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << run.err;
  EXPECT_NE(run.err.find("--device cuda: this build has no CUDA"), std::string::npos) << run.err;
}

TEST(SparseDepthWarnings, EachSuspicionHasItsMessage) {
  EXPECT_TRUE(sparse_depth_warnings(500, 0, 400, 1.2, true).empty());
  EXPECT_TRUE(sparse_depth_warnings(5000, 120000, 4000, 0.9, true).empty());
  const auto one = [](const std::vector<std::string>& w, const std::string& text) {
    return w.size() == 1 && w[0].find(text) != std::string::npos;
  };
  EXPECT_TRUE(one(sparse_depth_warnings(300, 120000, 250, 1.0, true), "only 300 of"));
  EXPECT_TRUE(one(sparse_depth_warnings(10, 0, 0, 1.0, true), "no sparse depth sample"));
  EXPECT_TRUE(one(sparse_depth_warnings(500, 0, 400, 3.9, true), "a factor of 3.9"));
  EXPECT_TRUE(one(sparse_depth_warnings(500, 0, 400, 0.256, true), "--depth-scale"));
  // A COLMAP reconstruction's units are arbitrary: any factor is expected.
  EXPECT_TRUE(sparse_depth_warnings(500, 0, 400, 0.01, false).empty());
}

}  // namespace
}  // namespace omnipoint::predict
