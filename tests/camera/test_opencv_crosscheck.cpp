// Cross-checks against OpenCV (a test-only dependency): cv::projectPoints for projection and
// cv::undistortPoints for the inverse of OPENCV and FULL_OPENCV. OpenCV's principal point is
// ours - 0.5 (pixel centres at integers).
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>

#include "omnipoint/camera/camera.h"

namespace omnipoint::camera {
namespace {

struct OpenCVCamera {
  cv::Matx33d matrix;
  std::vector<double> distortion;
};

OpenCVCamera to_opencv(const Camera& camera) {
  const auto& p = camera.params();
  return {cv::Matx33d(p[0], 0, p[2] - 0.5, 0, p[1], p[3] - 0.5, 0, 0, 1),
          std::vector<double>(p.begin() + 4, p.end())};
}

std::vector<cv::Point3d> front_points(int count) {
  cv::RNG rng(11);
  std::vector<cv::Point3d> points;
  for (int i = 0; i < count; ++i) {
    const double z = rng.uniform(0.5, 20.0);
    points.emplace_back(rng.uniform(-0.9, 0.9) * z, rng.uniform(-0.6, 0.6) * z, z);
  }
  return points;
}

class OpenCVCrossCheck : public ::testing::TestWithParam<std::string> {};

TEST_P(OpenCVCrossCheck, ProjectPoints) {
  const auto camera = parse_camera(GetParam());
  const auto cv_camera = to_opencv(camera);
  const auto points = front_points(2000);
  std::vector<cv::Point2d> expected;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), cv_camera.matrix,
                    cv_camera.distortion, expected);

  const auto ours = camera.project(
      at::from_blob(const_cast<cv::Point3d*>(points.data()), {2000, 3}, at::kDouble).clone());
  ASSERT_TRUE(ours.valid.all().item<bool>());
  double max_error = 0;
  for (int i = 0; i < 2000; ++i) {
    max_error =
        std::max(max_error, std::hypot(ours.pixels[i][0].item<double>() - (expected[i].x + 0.5),
                                       ours.pixels[i][1].item<double>() - (expected[i].y + 0.5)));
  }
  EXPECT_LE(max_error, 1e-3);
}

TEST_P(OpenCVCrossCheck, UndistortPoints) {
  const auto camera = parse_camera(GetParam());
  const auto cv_camera = to_opencv(camera);
  const auto map = camera.ray_map(at::kDouble);
  ASSERT_TRUE(map.valid.all().item<bool>());
  std::vector<cv::Point2d> pixels, normalised;
  for (int64_t y = 0; y < camera.height(); y += 7) {
    for (int64_t x = 0; x < camera.width(); x += 7)
      pixels.emplace_back(x, y);  // centre (x+0.5, y+0.5)
  }
  cv::undistortPoints(
      pixels, normalised, cv_camera.matrix, cv_camera.distortion, cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 200, 1e-14));
  double max_error_px = 0, max_ray_error = 0;
  std::size_t k = 0;
  for (int64_t y = 0; y < camera.height(); y += 7) {
    for (int64_t x = 0; x < camera.width(); x += 7, ++k) {
      const auto ray = map.rays[y][x];
      const double rz = ray[2].item<double>();
      const double ex = normalised[k].x, ey = normalised[k].y;
      max_error_px =
          std::max(max_error_px, camera.params()[0] * std::hypot(ray[0].item<double>() / rz - ex,
                                                                 ray[1].item<double>() / rz - ey));
      const double n = std::sqrt(ex * ex + ey * ey + 1);
      max_ray_error = std::max(max_ray_error, std::hypot(std::hypot(ray[0].item<double>() - ex / n,
                                                                    ray[1].item<double>() - ey / n),
                                                         rz - 1 / n));
    }
  }
  EXPECT_LE(max_error_px, 1e-3);
  EXPECT_LE(max_ray_error, 1e-4);
}

INSTANTIATE_TEST_SUITE_P(
    Models, OpenCVCrossCheck,
    ::testing::Values(
        "OPENCV 320 240 260 262 160.5 119.5 -0.28 0.09 0.0008 -0.0005",
        "FULL_OPENCV 320 240 220 221 160 120 -0.25 0.07 0.0005 -0.0003 0.01 0.02 0.005 0.001"),
    [](const ::testing::TestParamInfo<std::string>& info) {
      return info.param.substr(0, info.param.find(' '));
    });

}  // namespace
}  // namespace omnipoint::camera
