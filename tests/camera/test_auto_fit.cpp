// fit_camera_auto: the model chosen by residual among the plausible candidates, and the
// angular residuals it reports.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/fit.h"
#include "support/expect_error.h"

namespace omnipoint::camera {
namespace {

CameraFit fit_auto(const Camera& truth) {
  const Rays map = truth.ray_map(at::kFloat);
  return fit_camera_auto(truth.width(), truth.height(), map.rays, map.valid);
}

TEST(FitCameraAuto, PinholeRaysGivePinhole) {
  // A wide pinhole (114 degrees diagonally) too: it must not become a fisheye.
  for (const std::string spec :
       {"PINHOLE 640 480 525 523 319.5 241", "PINHOLE 320 240 100 100 160 120"}) {
    const Camera truth = parse_camera(spec);
    const CameraFit fit = fit_auto(truth);
    EXPECT_EQ(fit.camera.model_name(), "PINHOLE") << spec;
    for (std::size_t i = 0; i < 4; ++i)
      EXPECT_NEAR(fit.camera.params()[i], truth.params()[i], 1e-3) << spec;
    EXPECT_LT(fit.residual.median_deg, 1e-3) << spec;
    EXPECT_LT(fit.residual.max_deg, 1e-3) << spec;
  }
}

TEST(FitCameraAuto, FisheyeRaysGiveAFisheyeModel) {
  // 184 degrees across the image, 260 across its diagonal.
  const Camera truth = parse_camera("OPENCV_FISHEYE 320 320 100 100 160 160 0.02 -0.005 0 0");
  const CameraFit fit = fit_auto(truth);
  EXPECT_EQ(fit.camera.model_name(), "OPENCV_FISHEYE");
  EXPECT_LT(fit.residual.median_deg, 1e-3);
  EXPECT_LT(fit.residual.max_deg, 1e-2);
  // A unified lens is fitted by the simplest model that explains it (UCM), not a polynomial.
  const CameraFit unified = fit_auto(parse_camera("UCM 320 240 110 110 160 120 0.6"));
  EXPECT_EQ(unified.camera.model_name(), "UCM");
  EXPECT_LT(unified.residual.max_deg, 1e-3);
}

// Predicted rays are noisy: the noise (0.3 degrees) must not make a pinhole a fisheye (the
// 196-degree OPENCV_FISHEYE of issue 14), nor the fisheye a pinhole.
at::Tensor noisy(const at::Tensor& rays, uint64_t seed) {
  const auto noise =
      at::randn(rays.sizes(), at::make_generator<at::CPUGeneratorImpl>(seed)) * 0.005;
  const auto moved = rays + noise;
  return moved / moved.norm(2, -1, true);
}

TEST(FitCameraAuto, NoiseDoesNotChangeTheModel) {
  for (const std::string spec : {"PINHOLE 320 240 250 250 160 120",
                                 "OPENCV_FISHEYE 320 240 90 90 160 120 0.02 -0.005 0 0"}) {
    const Camera truth = parse_camera(spec);
    const Rays map = truth.ray_map(at::kFloat);
    const CameraFit fit = fit_camera_auto(320, 240, noisy(map.rays, 5), map.valid);
    EXPECT_EQ(fit.camera.model_name(), truth.model_name()) << spec;
    // The noise's own angle: median ~0.005 * sqrt(2 ln 2) rad = 0.34 degrees.
    EXPECT_NEAR(fit.residual.median_deg, 0.34, 0.05) << spec;
    EXPECT_NEAR(fit.camera.params()[0], truth.params()[0], 0.01 * truth.params()[0]) << spec;
  }
}

TEST(FitCameraAuto, PanoramaRaysGiveEquirectangular) {
  for (const std::string spec :
       {"EQUIRECTANGULAR 256 128", "EQUIRECTANGULAR 200 100 -1.5 1.5 -0.7 0.8"}) {
    const CameraFit fit = fit_auto(parse_camera(spec));
    EXPECT_EQ(fit.camera.model_name(), "EQUIRECTANGULAR") << spec;
    EXPECT_LT(fit.residual.max_deg, 1e-3) << spec;
  }
}

// Residuals are angles in degrees: a pinhole whose focal is 1 % off, checked at the widest
// pixel against the closed form.
TEST(FitCameraAuto, ResidualIsTheAngleBetweenRays) {
  const Camera truth = parse_camera("PINHOLE 64 48 50 50 32 24");
  const Camera off = parse_camera("PINHOLE 64 48 50.5 50.5 32 24");
  const Rays map = truth.ray_map(at::kDouble);
  const AngularResidual residual = angular_residual(off, map.rays, map.valid);
  // The corner pixel centre (0.5, 0.5): radius r = |(31.5, 23.5)| from the principal point.
  const double r = std::hypot(31.5, 23.5);
  const double expected_max = (std::atan(r / 50) - std::atan(r / 50.5)) * 180 / M_PI;
  EXPECT_NEAR(residual.max_deg, expected_max, 1e-9);
  EXPECT_GT(residual.median_deg, 0);
  EXPECT_LT(residual.median_deg, residual.max_deg);
  // Pixels where the camera has no ray count 180 degrees: a fisheye whose image circle leaves
  // the corners out, against the pinhole's rays everywhere.
  const Camera narrow = parse_camera("OPENCV_FISHEYE 64 48 10 10 32 24 0 0 0 0");
  ASSERT_FALSE(narrow.ray_map().valid.all().item<bool>());
  EXPECT_EQ(angular_residual(narrow, map.rays, map.valid).max_deg, 180.0);
}

TEST(FitCameraAuto, NamedModelReportsItsResidual) {
  const Camera truth = parse_camera("OPENCV_FISHEYE 320 320 100 100 160 160 0.02 -0.005 0 0");
  const Rays map = truth.ray_map(at::kFloat);
  const CameraFit forced = fit_camera_model("PINHOLE", 320, 320, map.rays, map.valid);
  EXPECT_EQ(forced.camera.model_name(), "PINHOLE");
  EXPECT_GT(forced.residual.max_deg, 45.0);  // rays near and behind 90 degrees: no pinhole has them
  EXPECT_GT(forced.residual.median_deg, 1.0);
  const CameraFit right = fit_camera_model("OPENCV_FISHEYE", 320, 320, map.rays, map.valid);
  EXPECT_LT(right.residual.max_deg, 1e-2);
}

TEST(FitCameraAuto, CandidatesFollowTheFieldOfView) {
  EXPECT_EQ(auto_fit_candidates(40),
            (std::vector<std::string>{"PINHOLE", "UCM", "OPENCV_FISHEYE"}));
  EXPECT_EQ(auto_fit_candidates(100),
            (std::vector<std::string>{"EQUIRECTANGULAR", "UCM", "OPENCV_FISHEYE"}));
  EXPECT_EQ(auto_fit_candidates(175), (std::vector<std::string>{"EQUIRECTANGULAR"}));
}

TEST(FitCameraAuto, RejectsTooFewRays) {
  test::expect_error<std::invalid_argument>(
      [] {
        fit_camera_auto(8, 8, at::zeros({8, 8, 3}), at::zeros({8, 8}, at::kBool));
      },
      {"fit_camera_auto", "at least 16 valid rays"});
}

// The three kinds at 640x480, exact and noisy: the true model is chosen. (Their timing is
// bench/bench_camera_fit.cpp's, docs/PERFORMANCE.md.)
TEST(FitCameraAuto, ChoosesTheTrueModelAt640x480) {
  for (const std::string spec :
       {"PINHOLE 640 480 525 523 319.5 241",
        "OPENCV_FISHEYE 640 480 180 180 320 240 0.02 -0.005 0 0", "EQUIRECTANGULAR 640 320"}) {
    const Camera truth = parse_camera(spec);
    const Rays map = truth.ray_map(at::kFloat);
    for (const bool with_noise : {false, true}) {
      const at::Tensor rays = with_noise ? noisy(map.rays, 6) : map.rays;
      const CameraFit fit = fit_camera_auto(640, truth.height(), rays, map.valid);
      EXPECT_EQ(fit.camera.model_name(), truth.model_name()) << spec << with_noise;
    }
  }
}

}  // namespace
}  // namespace omnipoint::camera
