// Cross-checks against OpenCV, forward and inverse, to 1e-3 px: cv::fisheye for
// OPENCV_FISHEYE and cv::omnidir (opencv_contrib) for MEI. OpenCV puts pixel centres at
// integers, we at +0.5: cx_opencv = cx - 0.5, and OpenCV's pixels are ours - 0.5.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>

#include <cmath>
#include <vector>

#include "omnipoint/camera/camera.h"

namespace omnipoint::camera {
namespace {

constexpr double kPixelTolerance = 1e-3;

// fx fy cx cy k1 k2 k3 k4 of a 1280 x 960 fisheye over 180 degrees.
const std::vector<double> kFisheye = {372.4,  371.8,   641.3,  478.9,
                                      0.0412, -0.0113, 0.0019, -0.00021};
// fx fy cx cy xi k1 k2 p1 p2 of a 1280 x 960 MEI camera (xi > 1: over 180 degrees).
const std::vector<double> kMei = {781.6,  780.2, 639.4,   481.7,   1.42,
                                  -0.217, 0.094, 0.00037, -0.00052};

cv::Matx33d opencv_matrix(const std::vector<double>& p) {
  return {p[0], 0, p[2] - 0.5, 0, p[1], p[3] - 0.5, 0, 0, 1};
}

at::Tensor random_directions(int64_t count) {
  at::manual_seed(3);
  const auto directions = at::randn({count, 3}, at::kDouble);
  return directions / directions.norm(2, -1, true);
}

std::vector<cv::Vec3d> to_points(const at::Tensor& rays) {
  const auto r = rays.contiguous();
  std::vector<cv::Vec3d> points;
  for (int64_t i = 0; i < r.size(0); ++i) {
    points.emplace_back(r[i][0].item<double>(), r[i][1].item<double>(), r[i][2].item<double>());
  }
  return points;
}

std::vector<cv::Vec2d> to_opencv_pixels(const at::Tensor& pixels) {
  std::vector<cv::Vec2d> out;
  for (int64_t i = 0; i < pixels.size(0); ++i) {
    out.emplace_back(pixels[i][0].item<double>() - 0.5, pixels[i][1].item<double>() - 0.5);
  }
  return out;
}

// Pixel centres on a coarse grid over the image, (N, 2).
at::Tensor pixel_grid(const Camera& camera) {
  return camera.pixel_centres(at::kDouble)
      .slice(0, 0, camera.height(), 16)
      .slice(1, 0, camera.width(), 16)
      .reshape({-1, 2});
}

// Rows of `values` where `keep` holds.
at::Tensor rows(const at::Tensor& values, const at::Tensor& keep) {
  return values.index_select(0, keep.nonzero().squeeze(1));
}

TEST(OpenCVCrossCheck, FisheyeProjectPoints) {
  const Camera camera("OPENCV_FISHEYE", 1280, 960, kFisheye);
  // cv::fisheye takes θ = atan(r / z): only the front hemisphere.
  const auto all = random_directions(5000);
  const auto rays = rows(all, all.select(-1, 2) > 0.02);
  const auto ours = camera.project(rays);
  ASSERT_TRUE(ours.valid.all().item<bool>());
  std::vector<cv::Vec2d> theirs;
  cv::fisheye::projectPoints(to_points(rays), theirs, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                             opencv_matrix(kFisheye),
                             cv::Vec4d(kFisheye[4], kFisheye[5], kFisheye[6], kFisheye[7]));
  double max_error = 0;
  for (int64_t i = 0; i < rays.size(0); ++i) {
    max_error =
        std::max(max_error, std::hypot(ours.pixels[i][0].item<double>() - 0.5 - theirs[i][0],
                                       ours.pixels[i][1].item<double>() - 0.5 - theirs[i][1]));
  }
  EXPECT_LE(max_error, kPixelTolerance);
}

TEST(OpenCVCrossCheck, FisheyeUndistortPoints) {
  const Camera camera("OPENCV_FISHEYE", 1280, 960, kFisheye);
  const auto grid = pixel_grid(camera);
  const auto ours_all = camera.unproject(grid);
  // cv::fisheye::undistortPoints returns x / z: pixels up to 80 degrees off-axis.
  const auto keep = ours_all.valid & (ours_all.rays.select(-1, 2) > std::cos(80.0 * M_PI / 180));
  const auto pixels = rows(grid, keep);
  const auto ours = rows(ours_all.rays, keep);
  ASSERT_GT(pixels.size(0), 1000);
  std::vector<cv::Vec2d> theirs;
  cv::fisheye::undistortPoints(
      to_opencv_pixels(pixels), theirs, opencv_matrix(kFisheye),
      cv::Vec4d(kFisheye[4], kFisheye[5], kFisheye[6], kFisheye[7]), cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::MAX_ITER + cv::TermCriteria::EPS, 100, 1e-14));
  // The angle between the rays, times the focal length: the pixel error at the centre's scale.
  double max_error = 0;
  for (int64_t i = 0; i < pixels.size(0); ++i) {
    const cv::Vec3d ray = cv::normalize(cv::Vec3d(theirs[i][0], theirs[i][1], 1.0));
    const cv::Vec3d our(ours[i][0].item<double>(), ours[i][1].item<double>(),
                        ours[i][2].item<double>());
    max_error = std::max(max_error, cv::norm(ray - our) * kFisheye[0]);
  }
  EXPECT_LE(max_error, kPixelTolerance);
}

TEST(OpenCVCrossCheck, MeiProjectPointsBeyondNinetyDegrees) {
  const Camera camera("MEI", 1280, 960, kMei);
  const auto all = random_directions(5000);
  const auto projected = camera.project(all);
  const auto rays = rows(all, projected.valid);
  const auto ours = rows(projected.pixels, projected.valid);
  ASSERT_GT((rays.select(-1, 2) < -0.3).sum().item<int64_t>(), 100) << "few rays behind the camera";
  std::vector<cv::Vec2d> theirs;
  const cv::Vec4d distortion(kMei[5], kMei[6], kMei[7], kMei[8]);
  cv::omnidir::projectPoints(to_points(rays), theirs, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                             opencv_matrix(kMei), kMei[4], distortion);
  double max_error = 0;
  for (int64_t i = 0; i < rays.size(0); ++i) {
    max_error = std::max(max_error, std::hypot(ours[i][0].item<double>() - 0.5 - theirs[i][0],
                                               ours[i][1].item<double>() - 0.5 - theirs[i][1]));
  }
  EXPECT_LE(max_error, kPixelTolerance);
}

TEST(OpenCVCrossCheck, MeiUndistortPoints) {
  const Camera camera("MEI", 1280, 960, kMei);
  const auto grid = pixel_grid(camera);
  const auto ours_all = camera.unproject(grid);
  const auto pixels = rows(grid, ours_all.valid);
  const auto ours = rows(ours_all.rays, ours_all.valid);
  ASSERT_GT((ours.select(-1, 2) < -0.2).sum().item<int64_t>(), 100)
      << "few pixels beyond 90 degrees";
  // cv::omnidir::undistortPoints returns (x / z, y / z) of the unit ray (x, y, z): the line of
  // the ray, for rays behind the camera too. Compared as lines, away from z = 0.
  std::vector<cv::Vec2d> theirs;
  const cv::Vec4d distortion(kMei[5], kMei[6], kMei[7], kMei[8]);
  cv::omnidir::undistortPoints(to_opencv_pixels(pixels), theirs, opencv_matrix(kMei), distortion,
                               cv::Matx<double, 1, 1>(kMei[4]), cv::Matx33d::eye());
  double max_error = 0;
  int64_t compared = 0;
  for (int64_t i = 0; i < pixels.size(0); ++i) {
    const cv::Vec3d our(ours[i][0].item<double>(), ours[i][1].item<double>(),
                        ours[i][2].item<double>());
    if (std::abs(our[2]) < 0.05) continue;
    const cv::Vec3d line = cv::normalize(cv::Vec3d(theirs[i][0], theirs[i][1], 1.0));
    max_error = std::max(max_error, std::min(cv::norm(line - our), cv::norm(line + our)) * kMei[0]);
    ++compared;
  }
  EXPECT_GT(compared, 1000);
  EXPECT_LE(max_error, kPixelTolerance);
}

}  // namespace
}  // namespace omnipoint::camera
