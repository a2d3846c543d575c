// EQUIRECTANGULAR: the seam, the poles, rays behind the camera, cropped panoramas.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>

#include "omnipoint/camera/camera.h"

namespace omnipoint::camera {
namespace {

at::Tensor pixel(double x, double y) {
  return at::tensor({x, y}, at::kDouble);
}
at::Tensor point(double x, double y, double z) {
  return at::tensor({x, y, z}, at::kDouble);
}

void expect_ray(const Rays& rays, double x, double y, double z) {
  ASSERT_TRUE(rays.valid.item<bool>());
  EXPECT_NEAR(rays.rays[0].item<double>(), x, 1e-12);
  EXPECT_NEAR(rays.rays[1].item<double>(), y, 1e-12);
  EXPECT_NEAR(rays.rays[2].item<double>(), z, 1e-12);
}

void expect_pixel(const Pixels& pixels, double x, double y) {
  ASSERT_TRUE(pixels.valid.item<bool>());
  EXPECT_NEAR(pixels.pixels[0].item<double>(), x, 1e-9);
  EXPECT_NEAR(pixels.pixels[1].item<double>(), y, 1e-9);
}

const Camera kPanorama = make_camera("EQUIRECTANGULAR", 2048, 1024, {});

TEST(Equirectangular, AxesFollowTheConvention) {
  expect_ray(kPanorama.unproject(pixel(1024, 512)), 0, 0, 1);  // centre: forward
  expect_ray(kPanorama.unproject(pixel(1536, 512)), 1, 0, 0);  // theta = +90 deg: right
  expect_ray(kPanorama.unproject(pixel(512, 512)), -1, 0, 0);  // left
  expect_ray(kPanorama.unproject(pixel(1024, 256)), 0, -std::sqrt(0.5),
             std::sqrt(0.5));  // 45 deg up
  expect_pixel(kPanorama.project(point(2, 0, 0)), 1536, 512);
  expect_pixel(kPanorama.project(point(0, 3, 3)), 1024, 768);  // 45 deg down
}

TEST(Equirectangular, SeamJoins) {
  expect_ray(kPanorama.unproject(pixel(0, 512)), 0, 0, -1);
  expect_ray(kPanorama.unproject(pixel(2048, 512)), 0, 0, -1);
  // Just either side of the seam the rays are neighbours.
  const auto left = kPanorama.unproject(pixel(1e-3, 300)).rays;
  const auto right = kPanorama.unproject(pixel(2048 - 1e-3, 300)).rays;
  EXPECT_LT((left - right).norm().item<double>(), 2 * M_PI * 2e-3 / 2048);
  // Straight back with a little +x is theta ~ +pi (right edge), with a little -x theta ~ -pi.
  EXPECT_NEAR(kPanorama.project(point(1e-6, 0, -1)).pixels[0].item<double>(), 2048, 1e-3);
  EXPECT_NEAR(kPanorama.project(point(-1e-6, 0, -1)).pixels[0].item<double>(), 0, 1e-3);
}

TEST(Equirectangular, RayBehindTheCameraIsValid) {
  const auto projected = kPanorama.project(point(0.3, -0.2, -2));
  ASSERT_TRUE(projected.valid.item<bool>());
  const auto back = kPanorama.unproject(projected.pixels);
  const auto expected = point(0.3, -0.2, -2) / point(0.3, -0.2, -2).norm();
  EXPECT_LT((back.rays - expected).abs().max().item<double>(), 1e-12);
}

TEST(Equirectangular, Poles) {
  expect_ray(kPanorama.unproject(pixel(700, 0)), 0, -1, 0);
  expect_ray(kPanorama.unproject(pixel(10, 1024)), 0, 1, 0);
  EXPECT_NEAR(kPanorama.project(point(0, -5, 0)).pixels[1].item<double>(), 0, 1e-12);
  EXPECT_NEAR(kPanorama.project(point(0, 5, 0)).pixels[1].item<double>(), 1024, 1e-12);
  // Beyond the poles there is nothing: invalid, zero.
  const auto beyond = kPanorama.unproject(pixel(700, -3));
  EXPECT_FALSE(beyond.valid.item<bool>());
  EXPECT_EQ(beyond.rays.abs().max().item<double>(), 0);
  // Float32 pixels on the pole rows stay valid.
  const auto rows = at::tensor({5.0f, 0.0f, 5.0f, 1024.0f}).view({2, 2});
  EXPECT_TRUE(kPanorama.unproject(rows).valid.all().item<bool>());
}

TEST(Equirectangular, CroppedPanorama) {
  const auto cropped = make_camera("EQUIRECTANGULAR", 400, 300, {-1.0, 1.0, -0.5, 1.0});
  // Corners and centre map to the stated bounds.
  const auto corner = cropped.unproject(pixel(0, 0)).rays;
  EXPECT_NEAR(std::atan2(corner[0].item<double>(), corner[2].item<double>()), -1.0, 1e-12);
  EXPECT_NEAR(std::asin(-corner[1].item<double>()), 1.0, 1e-12);
  const auto far_corner = cropped.unproject(pixel(400, 300)).rays;
  EXPECT_NEAR(std::atan2(far_corner[0].item<double>(), far_corner[2].item<double>()), 1.0, 1e-12);
  EXPECT_NEAR(std::asin(-far_corner[1].item<double>()), -0.5, 1e-12);
  // Cropping the full panorama gives the same camera as the explicit cropped form.
  const auto from_full = kPanorama.cropped(512, 256, 1024, 256);
  ASSERT_EQ(from_full.params().size(), 4u);
  EXPECT_NEAR(from_full.params()[0], -M_PI / 2, 1e-15);
  EXPECT_NEAR(from_full.params()[1], M_PI / 2, 1e-15);
  EXPECT_NEAR(from_full.params()[2], 0, 1e-15);
  EXPECT_NEAR(from_full.params()[3], M_PI / 4, 1e-15);
}

TEST(Equirectangular, CropAcrossTheSeam) {
  // Longitudes 2.5 .. 3.8 cross +-pi; a direction at longitude -3 (= 3.283) lies inside.
  const auto cropped = make_camera("EQUIRECTANGULAR", 130, 100, {2.5, 3.8, -0.5, 0.5});
  const auto projected = cropped.project(point(std::sin(-3.0), 0, std::cos(-3.0)));
  expect_pixel(projected, (2 * M_PI - 3 - 2.5) / 1.3 * 130, 50);
}

}  // namespace
}  // namespace omnipoint::camera
