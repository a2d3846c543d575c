// End-to-end: `omnipoint camera rays` for fisheye cameras matches independent evaluations to
// 1e-4 in ray direction, invalid pixels included: OpenCV's cv::fisheye and cv::omnidir, and
// for a lens of 250 degrees (beyond cv::fisheye's hemisphere) a scalar Kannala-Brandt
// inverse written here. OpenCV's pixel centres are ours - 0.5.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/calib3d.hpp>
#include <opencv2/ccalib/omnidir.hpp>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "omnipoint/io/npy.h"
#include "support/cli_run.h"

namespace omnipoint::camera {
namespace {
namespace fs = std::filesystem;

constexpr double kRayTolerance = 1e-4;

class FisheyeCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("omnipoint_fisheye_cli_" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // `omnipoint camera rays` for the spec, as a (H, W, 3) float64 tensor.
  at::Tensor rays(const std::string& spec) const {
    const auto out = (dir_ / "rays.npy").string();
    const test::CliRun run =
        test::run_omnipoint("camera rays --camera '" + spec + "' --out " + out, dir_ / "cli");
    EXPECT_EQ(run.status, 0) << spec << ": " << run.err;
    const auto rays = io::read_npy(out);
    EXPECT_EQ(rays.scalar_type(), at::kFloat);
    return rays.to(at::kDouble);
  }

  fs::path dir_;
};

cv::Vec3d ray_at(const at::Tensor& rays, int64_t row, int64_t col) {
  const auto r = rays[row][col];
  return {r[0].item<double>(), r[1].item<double>(), r[2].item<double>()};
}

TEST_F(FisheyeCli, OpenCVFisheyeMatchesOpenCV) {
  const double p[] = {60.3, 60.1, 80.2, 59.7, 0.031, -0.0094, 0.0012, -0.00011};
  const auto rays =
      this->rays("OPENCV_FISHEYE 160 120 60.3 60.1 80.2 59.7 0.031 -0.0094 0.0012 -0.00011");
  ASSERT_EQ(rays.sizes(), (std::vector<int64_t>{120, 160, 3}));
  std::vector<cv::Vec2d> pixels;
  for (int row = 0; row < 120; ++row) {
    for (int col = 0; col < 160; ++col) pixels.emplace_back(col, row);  // centres, OpenCV's way
  }
  std::vector<cv::Vec2d> plane;
  cv::fisheye::undistortPoints(
      pixels, plane, cv::Matx33d(p[0], 0, p[2] - 0.5, 0, p[1], p[3] - 0.5, 0, 0, 1),
      cv::Vec4d(p[4], p[5], p[6], p[7]), cv::noArray(), cv::noArray(),
      cv::TermCriteria(cv::TermCriteria::MAX_ITER + cv::TermCriteria::EPS, 100, 1e-14));
  // cv::fisheye::undistortPoints returns x / z: the front hemisphere, here up to 80 degrees.
  double max_error = 0;
  int compared = 0;
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const cv::Vec3d expected = cv::normalize(cv::Vec3d(plane[i][0], plane[i][1], 1.0));
    if (expected[2] < std::cos(80.0 * M_PI / 180)) continue;
    max_error = std::max(max_error, cv::norm(ray_at(rays, i / 160, i % 160) - expected));
    ++compared;
  }
  EXPECT_GT(compared, 5000);
  EXPECT_LE(max_error, kRayTolerance);
}

TEST_F(FisheyeCli, MeiMatchesOpenCVOmnidir) {
  // ξ = 1.35: over 270 degrees, the sphere's fold inside the image (corners invalid).
  const double p[] = {56.3, 56.1, 80.4, 60.2, 1.35, -0.12, 0.05, 0.0006, -0.0004};
  const auto rays = this->rays("MEI 160 120 56.3 56.1 80.4 60.2 1.35 -0.12 0.05 0.0006 -0.0004");
  const cv::Matx33d k(p[0], 0, p[2] - 0.5, 0, p[1], p[3] - 0.5, 0, 0, 1);
  const cv::Vec4d distortion(p[5], p[6], p[7], p[8]);
  std::vector<cv::Vec2d> pixels;
  for (int row = 0; row < 120; ++row) {
    for (int col = 0; col < 160; ++col) pixels.emplace_back(col, row);
  }
  // cv::omnidir::undistortPoints gives the ray's line (x / z, y / z); of its two directions the
  // ray is the one cv::omnidir::projectPoints maps back onto the pixel. Pixels where neither
  // does have no ray (beyond the fold).
  std::vector<cv::Vec2d> line;
  cv::omnidir::undistortPoints(pixels, line, k, distortion, cv::Matx<double, 1, 1>(p[4]),
                               cv::Matx33d::eye());
  double max_error = 0;
  int beyond_ninety = 0, invalid = 0;
  for (std::size_t i = 0; i < pixels.size(); ++i) {
    const cv::Vec3d direction = cv::normalize(cv::Vec3d(line[i][0], line[i][1], 1.0));
    const std::vector<cv::Vec3d> candidates = {direction, -direction};
    std::vector<cv::Vec2d> back;
    cv::omnidir::projectPoints(candidates, back, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), k, p[4],
                               distortion);
    const cv::Vec3d ours = ray_at(rays, i / 160, i % 160);
    bool found = false;
    for (int c = 0; c < 2; ++c) {
      if (cv::norm(back[c] - pixels[i]) < 1e-3) {
        found = true;
        if (std::abs(candidates[c][2]) > 0.05) {  // x / z is ill-conditioned near z = 0
          max_error = std::max(max_error, cv::norm(ours - candidates[c]));
        }
        if (candidates[c][2] < -0.2) ++beyond_ninety;
      }
    }
    if (!found) {
      ++invalid;
      EXPECT_EQ(cv::norm(ours), 0.0) << "pixel " << pixels[i] << " has no ray in OpenCV";
    }
  }
  EXPECT_GT(beyond_ninety, 1000);
  EXPECT_GT(invalid, 500);
  EXPECT_LE(max_error, kRayTolerance);
}

// θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸) and its slope, for the scalar reference.
double theta_d(double t, const double* k) {
  return t *
         (1 + k[0] * t * t + k[1] * std::pow(t, 4) + k[2] * std::pow(t, 6) + k[3] * std::pow(t, 8));
}

TEST_F(FisheyeCli, WideKannalaBrandtMatchesAScalarInverse) {
  const double p[] = {45.9, 46.1, 79.8, 60.4, 0.0342, -0.0147, 0.0021, -0.0003};
  const auto rays =
      this->rays("OPENCV_FISHEYE 160 120 45.9 46.1 79.8 60.4 0.0342 -0.0147 0.0021 -0.0003");
  // The lens limit: where θ_d stops rising, from a fine scan (about 125 degrees).
  double limit = 0;
  while (limit < M_PI && theta_d(limit + 1e-5, p + 4) > theta_d(limit, p + 4)) limit += 1e-5;
  const double radius_max = theta_d(limit, p + 4);
  double max_error = 0;
  int beyond_ninety = 0, invalid = 0;
  for (int row = 0; row < 120; ++row) {
    for (int col = 0; col < 160; ++col) {
      const double mx = (col + 0.5 - p[2]) / p[0], my = (row + 0.5 - p[3]) / p[1];
      const double radius = std::hypot(mx, my);
      if (std::abs(radius - radius_max) * p[0] < 0.05) continue;  // on the limit itself
      cv::Vec3d expected(0, 0, 0);
      if (radius < radius_max) {
        double low = 0, high = limit;
        for (int i = 0; i < 100; ++i) {
          const double mid = 0.5 * (low + high);
          (theta_d(mid, p + 4) < radius ? low : high) = mid;
        }
        const double theta = 0.5 * (low + high);
        const double scale = radius > 0 ? std::sin(theta) / radius : 0;
        expected = {mx * scale, my * scale, std::cos(theta)};
        if (expected[2] < -0.2) ++beyond_ninety;
      } else {
        ++invalid;
      }
      max_error = std::max(max_error, cv::norm(ray_at(rays, row, col) - expected));
    }
  }
  EXPECT_GT(beyond_ninety, 1000);
  EXPECT_GT(invalid, 100);
  EXPECT_LE(max_error, kRayTolerance);
}

}  // namespace
}  // namespace omnipoint::camera
