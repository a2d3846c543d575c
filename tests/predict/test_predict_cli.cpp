// omnipoint predict end to end: outputs per image, and each kind of bad input -> one line on
// stderr naming it, a non-zero exit, and no folder for the skipped image.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
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
          "mask.png", "depth.png", "depth_vis.png", "preview.png", "camera.json"})
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

}  // namespace
}  // namespace omnipoint::predict
