// End-to-end tests of `omnipoint reproject` on synth samples, and its errors.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/npy.h"
#include "support/cli_run.h"

namespace omnipoint {
namespace {
namespace fs = std::filesystem;

class ReprojectCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("omnipoint_reproject_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // A pinhole sample and a panorama sample of the same scene.
    ASSERT_EQ(run("synth --camera 'PINHOLE 96 72 60 60 48 36' --scene indoor --seed 4 --out " +
                  path("pin") + " --no-shadows --no-ao")
                  .status,
              0);
    ASSERT_EQ(run("synth --camera 'EQUIRECTANGULAR 384 192' --scene indoor --seed 4 --out " +
                  path("pano") + " --no-shadows --no-ao")
                  .status,
              0);
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }

  static test::CliRun run(const std::string& arguments) {
    return test::run_omnipoint(arguments, dir_ / "cli");
  }
  static std::string path(const std::string& name) { return (dir_ / name).string(); }

  void expect_failure(const std::string& arguments, const std::string& mention) {
    const auto result = run(arguments);
    EXPECT_NE(result.status, 0) << arguments;
    EXPECT_NE(result.err.find(mention), std::string::npos) << result.err;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_FALSE(fs::exists(path("bad"))) << arguments;
  }

  // Relative distance errors: within 1 % for 99 % of the valid pixels (as in test_p2a.cpp);
  // above 2 % for at most 0.5 % of them — objects thinner than a source pixel (chair legs,
  // lamp poles) that one sampling of the scene hits and the other misses.
  static void expect_agreement(const at::Tensor& d, const at::Tensor& g) {
    const auto error = ((d - g).abs() / g).to(at::kDouble);
    EXPECT_LE(error.quantile(0.99).item<double>(), 0.01);
    EXPECT_LE((error > 0.02).to(at::kDouble).mean().item<double>(), 0.005);
  }

  static fs::path dir_;
};
fs::path ReprojectCli::dir_;

TEST_F(ReprojectCli, PinholeSampleToPanoramaAgreesWithThePanoramaSample) {
  ASSERT_EQ(run("reproject --input " + path("pin/000004") +
                " --camera 'EQUIRECTANGULAR 384 192' --out " + path("p2a"))
                .status,
            0);
  const data::Sample out = data::read_sample(path("p2a"));
  const data::Sample truth = data::read_sample(path("pano/000004"));
  EXPECT_EQ(out.camera, truth.camera);
  EXPECT_TRUE(out.metric);
  const auto rays = io::read_npy(path("p2a/rays.npy"));
  EXPECT_TRUE(at::allclose(rays, truth.camera.ray_map(at::kFloat).rays));
  ASSERT_GT(out.mask.sum().item<int64_t>(), 200);
  ASSERT_EQ((out.mask & truth.mask.logical_not()).sum().item<int64_t>(), 0);
  const auto d = out.distance.masked_select(out.mask), g = truth.distance.masked_select(out.mask);
  expect_agreement(d, g);
  const auto meta = nlohmann::json::parse(io::read_file(path("p2a/meta.json")));
  EXPECT_EQ(meta.at("reproject").at("mode"), "camera");
}

TEST_F(ReprojectCli, PerspectiveViewOfAPanoramaAgreesWithThePinholeSample) {
  // The pinhole sample looks along the panorama's (yaw, pitch) = (0, 0): same pose.
  const double fov = 2 * std::atan(48.0 / 60.0) * 180 / M_PI;
  ASSERT_EQ(run("reproject --input " + path("pano/000004") + " --perspective " +
                std::to_string(fov) + " --width 96 --height 72 --out " + path("view"))
                .status,
            0);
  const data::Sample out = data::read_sample(path("view"));
  const data::Sample truth = data::read_sample(path("pin/000004"));
  EXPECT_EQ(out.camera.model_name(), "PINHOLE");
  EXPECT_TRUE(at::allclose(out.camera.ray_map().rays, truth.camera.ray_map().rays, 1e-5, 1e-5));
  ASSERT_GT(out.mask.sum().item<int64_t>(), 0.5 * truth.mask.sum().item<int64_t>());
  ASSERT_EQ((out.mask & truth.mask.logical_not()).sum().item<int64_t>(), 0);
  const auto d = out.distance.masked_select(out.mask), g = truth.distance.masked_select(out.mask);
  expect_agreement(d, g);
  EXPECT_LT((out.image - truth.image).abs().mean().item<double>(), 0.08);
}

TEST_F(ReprojectCli, BadInputsFailWithOneLine) {
  const std::string out = " --out " + path("bad");
  expect_failure("reproject --input " + path("missing") + " --camera 'EQUIRECTANGULAR 64 32'" + out,
                 "missing");
  expect_failure("reproject --input " + path("pin/000004") + " --camera 'NOPE 1 2'" + out, "NOPE");
  expect_failure("reproject --input " + path("pin/000004") + out, "--camera");
  expect_failure("reproject --input " + path("pano/000004") + " --perspective 190" + out,
                 "--perspective");
  expect_failure("reproject --input " + path("pin/000004") +
                     " --camera 'EQUIRECTANGULAR 64 32' --perspective 60" + out,
                 "excludes");
  expect_failure("reproject --input " + path("pin/000004") +
                     " --camera 'EQUIRECTANGULAR 64 32' --supersample 9" + out,
                 "supersample");
  EXPECT_EQ(run("reproject --help").status, 0);
}

}  // namespace
}  // namespace omnipoint
