// End-to-end tests of `omnipoint camera rays|info`.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "omnipoint/camera/camera.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/npy.h"
#include "support/cli_run.h"

namespace omnipoint::camera {
namespace {
namespace fs = std::filesystem;

using Result = omnipoint::test::CliRun;

class CameraCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("omnipoint_camera_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  Result run(const std::string& arguments) const { return test::run_omnipoint(arguments, dir_); }
  std::string path(const std::string& name) const { return (dir_ / name).string(); }

  // A failure: non-zero exit, one line on stderr naming the problem, no output file.
  void expect_failure(const std::string& arguments, const std::string& mention,
                      const std::string& output = "") {
    const auto result = run(arguments);
    EXPECT_NE(result.status, 0) << arguments;
    EXPECT_EQ(std::count(result.err.begin(), result.err.end(), '\n'), 1) << result.err;
    EXPECT_NE(result.err.find(mention), std::string::npos) << result.err;
    if (!output.empty()) {
      EXPECT_FALSE(fs::exists(output)) << output;
    }
    // No temporary files left behind either.
    for (const auto& entry : fs::directory_iterator(dir_)) {
      EXPECT_EQ(entry.path().filename().string().find(".tmp"), std::string::npos) << entry.path();
    }
  }

  fs::path dir_;
};

TEST_F(CameraCli, RaysMatchTheLibrary) {
  const std::string spec = "OPENCV 64 48 50 51 32.5 23.5 -0.2 0.05 0.001 -0.001";
  const auto result = run("camera rays --camera '" + spec + "' --out " + path("rays.npy"));
  ASSERT_EQ(result.status, 0) << result.err;
  const auto rays = io::read_npy(path("rays.npy"));
  ASSERT_EQ(rays.scalar_type(), at::kFloat);
  ASSERT_EQ(rays.sizes(), (std::vector<int64_t>{48, 64, 3}));
  const auto expected = parse_camera(spec).ray_map(at::kFloat).rays;
  EXPECT_TRUE(at::equal(rays, expected));
}

TEST_F(CameraCli, EquirectangularRaysMatchTheFormula) {
  const auto result = run("camera rays --camera 'EQUIRECTANGULAR 64 32' --out " + path("pano.npy"));
  ASSERT_EQ(result.status, 0) << result.err;
  const auto rays = io::read_npy(path("pano.npy"));
  double max_error = 0;
  for (int j = 0; j < 32; j += 3) {
    for (int i = 0; i < 64; i += 5) {
      const double theta = 2 * M_PI * ((i + 0.5) / 64 - 0.5), phi = M_PI * (0.5 - (j + 0.5) / 32);
      const double expected[3] = {std::cos(phi) * std::sin(theta), -std::sin(phi),
                                  std::cos(phi) * std::cos(theta)};
      for (int c = 0; c < 3; ++c)
        max_error = std::max(max_error, std::abs(rays[j][i][c].item<double>() - expected[c]));
    }
  }
  EXPECT_LE(max_error, 1e-6);
}

TEST_F(CameraCli, RaysFromAFileAndThePngPicture) {
  std::ofstream(path("cameras.txt"))
      << "# cameras\n1 PINHOLE 32 24 30 30 16 12\n2 FOV 40 30 20 20 20 15 0.9\n";
  const auto result = run("camera rays --camera " + path("cameras.txt") + "#2 --out " +
                          path("r.npy") + " --png " + path("r.png"));
  ASSERT_EQ(result.status, 0) << result.err;
  EXPECT_EQ(io::read_npy(path("r.npy")).sizes(), (std::vector<int64_t>{30, 40, 3}));
#ifdef OMNIPOINT_WITH_OPENCV
  EXPECT_EQ(io::read_file(path("r.png")).substr(1, 3), "PNG");
#endif
}

TEST_F(CameraCli, InfoPrintsJson) {
  const auto result = run("camera info --fov 90 --width 64 --height 48");
  ASSERT_EQ(result.status, 0) << result.err;
  const auto info = nlohmann::json::parse(result.out);
  EXPECT_EQ(info["model"], "PINHOLE");
  EXPECT_EQ(info["width"], 64);
  EXPECT_NEAR(info["fov_deg"]["horizontal"].get<double>(), 90, 1e-6);
  EXPECT_NEAR(info["fov_deg"]["vertical"].get<double>(), 2 * std::atan(24.0 / 32) * 180 / M_PI,
              1e-6);
  EXPECT_EQ(info["valid_fraction"], 1.0);

  const auto pano = nlohmann::json::parse(run("camera info --camera 'EQUIRECTANGULAR 64 32'").out);
  EXPECT_NEAR(pano["fov_deg"]["horizontal"].get<double>(), 360, 1e-6);
  EXPECT_NEAR(pano["fov_deg"]["vertical"].get<double>(), 180, 1e-6);
}

TEST_F(CameraCli, FitRecoversTheCameraOfARayMap) {
  const std::string spec = "OPENCV 96 72 80 81 48.5 35.5 -0.2 0.05 0.001 -0.001";
  ASSERT_EQ(run("camera rays --camera '" + spec + "' --out " + path("rays.npy")).status, 0);
  const auto result = run("camera fit --rays " + path("rays.npy") + " --model OPENCV");
  ASSERT_EQ(result.status, 0) << result.err;
  const auto fitted = parse_camera(nlohmann::json::parse(result.out)["spec"].get<std::string>());
  const auto truth = parse_camera(spec);
  ASSERT_EQ(fitted.model_name(), "OPENCV");
  // The ray map is float32: parameters to about float precision.
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(fitted.params()[i], truth.params()[i], 2e-3);
  for (std::size_t i = 4; i < 8; ++i) EXPECT_NEAR(fitted.params()[i], truth.params()[i], 1e-4);
  // Exact rays: the residual is tiny, and stated.
  const auto residual = nlohmann::json::parse(result.out)["fit_residual_deg"];
  EXPECT_LT(residual["max"].get<double>(), 0.01);
  EXPECT_LE(residual["median"].get<double>(), residual["max"].get<double>());
  // "auto" picks the simplest model that explains them, as predict --fit-model auto does: a
  // pinhole's rays give a PINHOLE.
  ASSERT_EQ(
      run("camera rays --camera 'PINHOLE 96 72 80 81 48.5 35.5' --out " + path("pinhole_rays.npy"))
          .status,
      0);
  const auto automatic = run("camera fit --rays " + path("pinhole_rays.npy") + " --model auto");
  ASSERT_EQ(automatic.status, 0) << automatic.err;
  const auto chosen = parse_camera(nlohmann::json::parse(automatic.out)["spec"].get<std::string>());
  EXPECT_EQ(chosen.model_name(), "PINHOLE");
  EXPECT_NEAR(chosen.params()[0], 80, 1e-2);
  expect_failure("camera fit --rays " + path("rays.npy") + " --model NOPE", "unknown camera model");
  expect_failure("camera fit --rays " + path("missing.npy") + " --model OPENCV", "missing.npy");
}

TEST_F(CameraCli, HelpEverywhere) {
  for (const std::string command : {"--help", "camera --help", "camera rays --help",
                                    "camera info --help", "camera fit --help"}) {
    const auto result = run(command);
    EXPECT_EQ(result.status, 0) << command;
    EXPECT_NE(result.out.find("Usage"), std::string::npos) << command;
  }
}

TEST_F(CameraCli, BadInputFailsCleanly) {
  const auto out = path("rays.npy");
  expect_failure("camera rays --camera 'PINHOLE 64 48 0 50 32 24' --out " + out,
                 "focal length fx must be > 0", out);
  expect_failure("camera rays --camera 'PINHOL 64 48 50 50 32 24' --out " + out,
                 "unknown camera model", out);
  expect_failure("camera rays --camera 'PINHOLE 64 48 50 50' --out " + out, "expects 4 parameters",
                 out);
  expect_failure("camera rays --camera " + path("missing.txt") + " --out " + out, "missing.txt",
                 out);
  expect_failure(
      "camera rays --camera 'PINHOLE 64 48 50 50 32 24' --out " + path("no/such/dir/r.npy"),
      "does not exist");
  expect_failure("camera rays --camera 'PINHOLE 64 48 50 50 32 24'", "--out");
  expect_failure("camera rays --fov 200 --width 64 --height 48 --out " + out, "--fov", out);
  expect_failure("camera info", "--camera");
}

}  // namespace
}  // namespace omnipoint::camera
