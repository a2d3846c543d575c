// Fitting recovers the camera that produced an exact ray map.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/fit.h"

namespace omnipoint::camera {
namespace {

void expect_recovers(const std::string& spec, double focal_tolerance, double distortion_tolerance) {
  const auto truth = parse_camera(spec);
  const auto map = truth.ray_map(at::kDouble);
  const auto fitted =
      fit_camera(truth.model_name(), truth.width(), truth.height(), map.rays, map.valid);
  ASSERT_EQ(fitted.model_name(), truth.model_name());
  const auto names = truth.model().param_names();
  for (std::size_t i = 0; i < names.size(); ++i) {
    const bool pixel_unit = names[i] == "f" || names[i] == "fx" || names[i] == "fy" ||
                            names[i] == "cx" || names[i] == "cy";
    EXPECT_NEAR(fitted.params()[i], truth.params()[i],
                pixel_unit ? focal_tolerance : distortion_tolerance)
        << names[i] << " of " << spec;
  }
}

TEST(FitCamera, RecoversPinhole) {
  expect_recovers("PINHOLE 320 240 250.5 252.25 160.5 119.75", 1e-6, 0);
}

TEST(FitCamera, RecoversOpenCV) {
  expect_recovers("OPENCV 320 240 250 252 160.5 119.5 -0.2 0.05 0.001 -0.0008", 1e-4, 1e-6);
}

TEST(FitCamera, RecoversFov) {
  expect_recovers("FOV 320 240 150 151 160 120 0.9", 1e-4, 1e-6);
}

TEST(FitCamera, RecoversOpenCVFisheye) {
  // Over 180 degrees: the fit uses rays behind the image plane too.
  expect_recovers("OPENCV_FISHEYE 320 240 92.6 92.4 160.3 119.6 0.025 -0.011 0.0016 -0.0001", 1e-4,
                  1e-6);
}

TEST(FitCamera, RecoversUnifiedModels) {
  expect_recovers("UCM 320 240 80.6 80.4 159.3 121.2 0.55", 1e-4, 1e-6);
  expect_recovers("EUCM 320 240 90.1 89.9 160.9 119.7 0.58 1.08", 1e-4, 1e-6);
  expect_recovers("DOUBLE_SPHERE 320 240 70.2 70.1 160.3 119.9 -0.2 0.55", 1e-4, 1e-6);
  expect_recovers("MEI 320 240 210.3 209.6 160.7 119.4 1.35 -0.12 0.05 0.0006 -0.0004", 1e-4, 1e-6);
}

TEST(FitCamera, RecoversCroppedPanorama) {
  expect_recovers("EQUIRECTANGULAR 128 64 -1.2 0.9 -0.6 0.7", 0, 1e-8);
}

TEST(FitCamera, FloatRayMapFitsToFloatPrecision) {
  const auto truth = parse_camera("PINHOLE 320 240 250.5 252.25 160.5 119.75");
  const auto map = truth.ray_map(at::kFloat);
  const auto fitted = fit_camera("PINHOLE", 320, 240, map.rays, map.valid);
  for (std::size_t i = 0; i < 4; ++i) EXPECT_NEAR(fitted.params()[i], truth.params()[i], 1e-3);
}

// At 12 MP the fit reads a regular grid of the pixels only (fit.h). Its camera equals that of a
// 16x denser subsample within fit.h's tolerance: on the exact rays every parameter within 1e-3
// relative (absolute below 1); on noisy rays, where the choice of rays matters, the median
// angular residual over the map within 0.01 degrees (the distortion terms alone are then only
// as well determined as the noise allows, for either subsample).
TEST(FitCamera, GridSubsampleAt12MegapixelsMatchesADenserOne) {
  for (const std::string spec :
       {"PINHOLE 4000 3000 3280 3270 1999.5 1501.25",
        "OPENCV_FISHEYE 4000 3000 1125 1124 2000.5 1499.5 0.02 -0.005 0.001 0",
        "EQUIRECTANGULAR 4000 2000 -2.8 2.9 -1.3 1.4"}) {
    const Camera truth = parse_camera(spec);
    const Rays map = truth.ray_map(at::kFloat);
    const int64_t width = truth.width(), height = truth.height();
    const auto grid_and_denser = [&](const at::Tensor& rays) {
      return std::pair{fit_camera(truth.model_name(), width, height, rays, map.valid),
                       fit_camera(truth.model_name(), width, height, rays, map.valid, 65536)};
    };
    const auto [grid, denser] = grid_and_denser(map.rays);
    for (std::size_t i = 0; i < truth.params().size(); ++i)
      EXPECT_NEAR(grid.params()[i], denser.params()[i],
                  1e-3 * std::max(1.0, std::abs(denser.params()[i])))
          << truth.model().param_names()[i] << " of " << spec;
    const at::Tensor moved =
        map.rays + at::randn(map.rays.sizes(), at::make_generator<at::CPUGeneratorImpl>(7)) * 0.002;
    const at::Tensor noisy = moved / moved.norm(2, -1, true);
    const auto [noisy_grid, noisy_denser] = grid_and_denser(noisy);
    EXPECT_NEAR(angular_residual(noisy_grid, noisy, map.valid).median_deg,
                angular_residual(noisy_denser, noisy, map.valid).median_deg, 0.01)
        << spec;
  }
}

TEST(FitCamera, RejectsBadInput) {
  const auto map = parse_camera("PINHOLE 32 24 25 25 16 12").ray_map(at::kDouble);
  EXPECT_THROW(fit_camera("PINHOLE", 24, 32, map.rays, map.valid), std::invalid_argument);
  EXPECT_THROW(fit_camera("PINHOLE", 32, 24, map.rays, at::zeros_like(map.valid)),
               std::invalid_argument);
  EXPECT_THROW(fit_camera("NOPE", 32, 24, map.rays, map.valid), std::invalid_argument);
}

// Several images of one camera fitted together: each image's valid rays are a different half of
// the picture, so only their union pins the camera down; from a start or the pinhole guess.
TEST(FitCameraToImages, RecoversTheCameraFromTheImagesTogether) {
  const Camera truth = parse_camera("UCM 64 48 30.6 30.4 32.3 23.8 0.55");
  const auto map = truth.ray_map(at::kDouble);
  const at::Tensor left = map.valid.clone(), right = map.valid.clone();
  left.slice(1, 32, 64).fill_(false);
  right.slice(1, 0, 32).fill_(false);
  const at::Tensor rays = at::stack({map.rays, map.rays});
  const at::Tensor valid = at::stack({left, right});
  const Camera start("UCM", 64, 48, {28, 28, 31, 25, 0.4});
  for (const Camera* from : {static_cast<const Camera*>(nullptr), &start}) {
    const CameraFit fit = fit_camera_model_to_images("UCM", 64, 48, rays, valid, from);
    for (size_t i = 0; i < truth.params().size(); ++i)
      EXPECT_NEAR(fit.camera.params()[i], truth.params()[i], 1e-4) << i;
    EXPECT_LT(fit.residual.max_deg, 1e-4);
  }
}

TEST(FitCameraToImages, RejectsBadInput) {
  const auto map = parse_camera("PINHOLE 32 24 25 25 16 12").ray_map(at::kDouble);
  const at::Tensor rays = map.rays.unsqueeze(0), valid = map.valid.unsqueeze(0);
  EXPECT_THROW(fit_camera_model_to_images("PINHOLE", 32, 24, map.rays, map.valid),
               std::invalid_argument);  // not a stack
  EXPECT_THROW(fit_camera_model_to_images("PINHOLE", 24, 32, rays, valid), std::invalid_argument);
  EXPECT_THROW(fit_camera_model_to_images("PINHOLE", 32, 24, rays, at::zeros_like(valid)),
               std::invalid_argument);
  const Camera other("UCM", 32, 24, {25, 25, 16, 12, 0.1});
  EXPECT_THROW(fit_camera_model_to_images("PINHOLE", 32, 24, rays, valid, &other),
               std::invalid_argument);
}

}  // namespace
}  // namespace omnipoint::camera
