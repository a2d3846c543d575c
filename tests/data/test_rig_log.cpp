// The "rig-log" reader (data/formats/rig_log.cpp): a manifest of frames with cameras given
// inline or as files, clouds in .bin layouts and transforms inline or as KITTI calibration
// files, written from known points and read back onto the right pixels; and its bad inputs.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "driving_files.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/io/image.h"
#include "support/scratch_dir.h"

namespace omnipoint::data {
namespace {

namespace fs = std::filesystem;
using test::expect_error;
using test::rigid;
using test::rotation;
using test::transformed;
using test::write_text;

const char* const kPinhole = "PINHOLE 32 24 30 30 16.5 11.25";
const char* const kFisheye = "OPENCV_FISHEYE 40 40 18 18 20 20 0.01 -0.002 0 0";

struct Truth {
  double u, v, distance;  // pixel coordinates (ours: pixel i spans [i, i+1))
};

// The points of `truth` in the camera frame.
at::Tensor truth_points(const camera::Camera& camera, const std::vector<Truth>& truth) {
  std::vector<double> pixels, distances;
  for (const Truth& t : truth) {
    pixels.insert(pixels.end(), {t.u, t.v});
    distances.push_back(t.distance);
  }
  const auto n = static_cast<int64_t>(truth.size());
  return camera.unproject(at::tensor(pixels, at::kDouble).view({n, 2})).rays *
         at::tensor(distances, at::kDouble).view({n, 1});
}

// A .bin of `floats` float32 per point (x, y, z, then padding values).
void write_bin(const fs::path& path, const at::Tensor& points, int64_t floats) {
  const at::Tensor records =
      at::cat({points.to(at::kFloat), at::full({points.size(0), floats - 3}, 7.0f)}, 1)
          .contiguous();
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary)
      .write(static_cast<const char*>(records.data_ptr()), records.numel() * sizeof(float));
}

void expect_labels(const Sample& sample, const std::vector<Truth>& truth, const std::string& what) {
  EXPECT_EQ(sample.mask.sum().item<int64_t>(), static_cast<int64_t>(truth.size())) << what;
  for (const Truth& t : truth) {
    const auto col = static_cast<int64_t>(t.u), row = static_cast<int64_t>(t.v);
    EXPECT_TRUE(sample.mask[row][col].item<bool>()) << what << " " << t.u << "," << t.v;
    EXPECT_NEAR(sample.distance[row][col].item<double>(), t.distance, 1e-4) << what;
  }
}

const std::vector<Truth> kPinholeTruth = {
    {3.25, 4.75, 6.0}, {20.75, 10.25, 11.5}, {31.5, 23.5, 4.0}};
const std::vector<Truth> kFisheyeTruth = {
    {2.25, 20.75, 3.0}, {20.25, 20.25, 8.5}, {35.75, 5.25, 5.25}};

TEST(RigLog, ManifestFramesBecomeSparseLabels) {
  if (!io::image_io_available()) GTEST_SKIP() << "no image file I/O in this build";
  const fs::path root = test::fresh_process_dir("omnipoint_rig_log");
  fs::create_directories(root / "front");
  fs::create_directories(root / "side");
  // Frame 1: the camera inline, a KITTI-layout .bin, the transform inline (row-major 4x4).
  const camera::Camera pinhole = camera::parse_camera(kPinhole);
  const at::Tensor lidar_from_camera =
      test::rigid(rotation(0.0, 0.6, 0.8, 0.7), at::tensor({0.3, -1.2, 0.5}, at::kDouble));
  write_bin(root / "lidar" / "a.bin",
            transformed(lidar_from_camera, truth_points(pinhole, kPinholeTruth)), 4);
  io::write_image_png((root / "front" / "a.png").string(), at::zeros({24, 32, 3}, at::kByte));
  std::string matrix;
  const at::Tensor camera_from_lidar = at::inverse(lidar_from_camera).contiguous().view(-1);
  for (int64_t i = 0; i < 16; ++i) {
    char number[40];
    std::snprintf(number, sizeof number, "%.17g", camera_from_lidar[i].item<double>());
    matrix += (i ? ", " : "") + std::string(number);
  }
  // Frame 2: the camera in a cameras.txt, a nuScenes-layout .bin, the transform as KITTI's
  // calib_velo_to_cam.txt.
  const camera::Camera fisheye = camera::parse_camera(kFisheye);
  const at::Tensor velo_rotation = rotation(1.0, 0.0, 0.0, -1.5);
  const at::Tensor velo_translation = at::tensor({0.1, 0.2, -0.3}, at::kDouble);
  write_text(root / "calib_velo_to_cam.txt",
             "calib_time: 15-Mar-2012 11:37:16\nR: " + test::kitti_numbers(velo_rotation) +
                 "\nT: " + test::kitti_numbers(velo_translation) + "\n");
  write_text(root / "side" / "cameras.txt", camera::to_cameras_txt(fisheye));
  write_bin(root / "lidar" / "b.bin",
            transformed(at::inverse(rigid(velo_rotation, velo_translation)),
                        truth_points(fisheye, kFisheyeTruth)),
            5);
  io::write_image_png((root / "side" / "b.png").string(), at::zeros({40, 40, 3}, at::kByte));
  write_text(root / "manifest.jsonl",
             std::string("{\"image\": \"front/a.png\", \"camera\": \"") + kPinhole +
                 "\", \"lidar\": \"lidar/a.bin\", \"lidar_to_camera\": [" + matrix +
                 "]}\n\n{\"image\": \"side/b.png\", \"camera\": \"side/cameras.txt\", "
                 "\"lidar\": \"lidar/b.bin\", \"lidar_to_camera\": \"calib_velo_to_cam.txt\", "
                 "\"lidar_format\": \"nuscenes\"}\n");

  const std::unique_ptr<Dataset> dataset = open_dataset("rig-log", {root.string()});
  ASSERT_EQ(dataset->size(), 2);
  EXPECT_EQ(dataset->item_name({1, 0}),
            (root / "manifest.jsonl").string() + " line 3: " + (root / "side" / "b.png").string());
  const Sample first = dataset->item({0, 0});
  EXPECT_EQ(first.camera.to_spec(), pinhole.to_spec());
  EXPECT_TRUE(first.metric);
  EXPECT_TRUE(first.sparse_labels);
  expect_labels(first, kPinholeTruth, "pinhole frame");
  const Sample second = dataset->item({1, 0});
  EXPECT_EQ(second.camera.to_spec(), fisheye.to_spec());
  expect_labels(second, kFisheyeTruth, "fisheye frame");

  // A line without a camera takes the option's; a split names another manifest.
  write_text(root / "val.jsonl",
             "{\"image\": \"front/a.png\", \"lidar\": \"lidar/a.bin\", "
             "\"lidar_to_camera\": [" +
                 matrix + "]}\n");
  const Sample optioned =
      open_dataset("rig-log",
                   {root.string(), false, (root / "val.jsonl").string(), {{"camera", kPinhole}}})
          ->item({0, 0});
  expect_labels(optioned, kPinholeTruth, "camera from the option");

  // Bad lines: one error naming the manifest's line and the problem.
  const auto open_with = [&](const std::string& line) {
    write_text(root / "bad.jsonl", "\n" + line + "\n");
    return open_dataset("rig-log", {root.string(), false, (root / "bad.jsonl").string()});
  };
  const std::string bad = (root / "bad.jsonl").string() + " line 2: ";
  expect_error([&] { open_with("{\"image\": \"front/a.png\""); }, {bad, "not a JSON object"});
  expect_error([&] { open_with("{\"lidar\": \"lidar/a.bin\"}"); }, {bad, "\"image\""});
  expect_error([&] { open_with("{\"image\": \"front/x.png\", \"lidar\": \"lidar/a.bin\"}"); },
               {bad, "no file", "x.png"});
  expect_error([&] { open_with("{\"image\": \"../a.png\", \"lidar\": \"lidar/a.bin\"}"); },
               {bad, "not a path under the root"});
  expect_error([&] { open_with("{\"image\": \"front/a.png\", \"lidar\": \"lidar/a.bin\"}"); },
               {bad, "no \"camera\""});
  expect_error(
      [&] {
        open_with(
            "{\"image\": \"front/a.png\", \"lidar\": \"lidar/a.bin\", \"camera\": "
            "\"PINHOLE 32 24 30\", \"lidar_to_camera\": [1, 0, 0, 0, 1, 0, 0, 0, 1]}");
      },
      {bad, "PINHOLE"});
  expect_error(
      [&] {
        open_with(std::string("{\"image\": \"front/a.png\", \"lidar\": \"lidar/a.bin\", "
                              "\"camera\": \"") +
                  kPinhole + "\", \"lidar_to_camera\": [1, 0, 0, 0, 1, 0, 0, 0, 1]}");
      },
      {bad, "got 9"});
  expect_error([&] { open_with("   "); }, {"names no frame"});
  // A cloud that is no whole number of records: the frame's error names the file.
  write_text(root / "lidar" / "a.bin", std::string(18, '\0'));
  expect_error([&] { dataset->item({0, 0}); }, {"a.bin"});
}

}  // namespace
}  // namespace omnipoint::data
