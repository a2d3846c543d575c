// LiDAR .bin layouts and the camera-from-LiDAR transform files (plain matrices, KITTI's).
#include "omnipoint/io/point_cloud.h"

#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "support/expect_error.h"

using omnipoint::io::parse_lidar_bin;
using omnipoint::io::parse_rigid_transform;
using omnipoint::test::expect_error;

namespace {

std::string floats(const std::vector<float>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
}

TEST(LidarBin, LayoutNames) {
  EXPECT_EQ(omnipoint::io::lidar_floats_per_point("kitti"), 4);
  EXPECT_EQ(omnipoint::io::lidar_floats_per_point("nuscenes"), 5);
  EXPECT_EQ(omnipoint::io::lidar_floats_per_point("7"), 7);
  for (const std::string bad : {"2", "-4", "4.5", "velodyne", "", "99999999999999999999"})
    expect_error<std::invalid_argument>(
        [&] { omnipoint::io::lidar_floats_per_point(bad); },
        {"LiDAR format '" + bad + "'", "expected kitti (4 floats per point), nuscenes (5)"});
}

TEST(LidarBin, KeepsXyzOfEachRecord) {
  // Two nuScenes records: x y z intensity ring.
  const std::string bytes = floats({1, 2, 3, 0.5f, 7, -4, 5.5f, 0, 1, 31});
  const at::Tensor points = parse_lidar_bin(bytes, "scan.bin", 5);
  EXPECT_TRUE(at::equal(points, at::tensor({1.0f, 2.0f, 3.0f, -4.0f, 5.5f, 0.0f}).view({2, 3})))
      << points;
  // The same bytes as 2.5 KITTI records do not fit; the message names the layout that does.
  expect_error<std::invalid_argument>(
      [&] { parse_lidar_bin(bytes, "scan.bin", 4); },
      {"sparse depth scan.bin", "40 bytes is not a multiple of 16 (4 float32 per point",
       "would fit: --lidar-format nuscenes (20 bytes per point)"});
  expect_error<std::invalid_argument>([&] { parse_lidar_bin("", "e.bin", 4); },
                                      {"e.bin", "is empty"});
  expect_error<std::invalid_argument>(
      [&] {
        parse_lidar_bin(floats({1, 2, 3, 4, 5, 6, 7}), "o.bin", 4);
      },
      {"o.bin", "28 bytes is not a multiple of 16"});
}

const char* const kKittiRaw =
    "calib_time: 15-Mar-2012 11:37:16\n"
    "R: 7.533745e-03 -9.999714e-01 -6.166020e-04 1.480249e-02 7.280733e-04 -9.998902e-01 "
    "9.998621e-01 7.523790e-03 1.480755e-02\n"
    "T: -4.069766e-03 -7.631618e-02 -2.717806e-01\n"
    "delta_f: 0.000000e+00 0.000000e+00\n"
    "delta_c: 0.000000e+00 0.000000e+00\n";

TEST(RigidTransform, ReadsKittiRawCalibVeloToCam) {
  const at::Tensor transform = parse_rigid_transform(kKittiRaw, "calib_velo_to_cam.txt");
  const at::Tensor expected =
      at::tensor({7.533745e-03, -9.999714e-01, -6.166020e-04, -4.069766e-03, 1.480249e-02,
                  7.280733e-04, -9.998902e-01, -7.631618e-02, 9.998621e-01, 7.523790e-03,
                  1.480755e-02, -2.717806e-01, 0.0, 0.0, 0.0, 1.0},
                 at::kDouble)
          .view({4, 4});
  EXPECT_TRUE(at::equal(transform, expected)) << transform;
}

TEST(RigidTransform, ReadsKittiOdometryCalibTr) {
  std::string text;
  for (int camera = 0; camera < 4; ++camera)
    text += "P" + std::to_string(camera) +
            ": 7.188560e+02 0 6.071928e+02 0 0 7.188560e+02 1.852157e+02 0 0 0 1 0\n";
  text += "Tr: 0 -1 0 0.1 0 0 -1 0.2 1 0 0 0.3\r\n";
  const at::Tensor transform = parse_rigid_transform(text, "calib.txt");
  EXPECT_TRUE(at::equal(transform, at::tensor({0.0, -1.0, 0.0, 0.1, 0.0, 0.0, -1.0, 0.2, 1.0, 0.0,
                                               0.0, 0.3, 0.0, 0.0, 0.0, 1.0},
                                              at::kDouble)
                                       .view({4, 4})))
      << transform;
}

TEST(RigidTransform, PlainMatricesStillRead) {
  EXPECT_TRUE(at::equal(
      parse_rigid_transform("1 0 0 0.5, 0 1 0 0, 0 0 1 0", "m.txt"),
      at::tensor({1.0, 0.0, 0.0, 0.5, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0},
                 at::kDouble)
          .view({4, 4})));
}

TEST(RigidTransform, KittiFilesWithMissingOrBadKeysAreErrors) {
  expect_error<std::invalid_argument>(
      [] { parse_rigid_transform("calib_time: today\nR: 1 0 0 0 1 0 0 0 1\n", "c.txt"); },
      {"camera-from-LiDAR c.txt", "needs T (raw calib_velo_to_cam.txt) or Tr",
       "found calib_time, R"});
  expect_error<std::invalid_argument>(
      [] { parse_rigid_transform("P0: 1 2 3\nP1: 4\n", "calib.txt"); },
      {"calib.txt", "needs R and T", "or Tr (odometry calib.txt); found P0, P1"});
  expect_error<std::invalid_argument>(
      [] { parse_rigid_transform("R: 1 0 0 0 1 0 0 0\nT: 0 0 0\n", "c.txt"); },
      {"c.txt", "R: expected 9 numbers, got 8"});
  expect_error<std::invalid_argument>(
      [] {
        parse_rigid_transform("Tr: 1 0 0 0 0 1 0 0 0 0 1 0\nTr: 1 0 0 0 0 1 0 0 0 0 1 0\n",
                              "c.txt");
      },
      {"c.txt", "the key Tr appears twice"});
  expect_error<std::invalid_argument>(
      [] { parse_rigid_transform("R: 1 0 0 0 1 0 0 0 1\nT 0 0 0\n", "c.txt"); },
      {"c.txt", "the line \"T 0 0 0\" is not \"KEY: values\""});
  expect_error<std::invalid_argument>(
      [] { parse_rigid_transform("R: 1 0 0 0 1 0 0 0 1\nT: 0 0 zero\n", "c.txt"); },
      {"c.txt T", "\"zero\" is not a number"});
}

}  // namespace
