#pragma once
// A rig's own logs in the "rig-log" layout (data/formats/rig_log.cpp) as the tests write them:
// a manifest of two frames from known points, one with its camera and transform inline and a
// KITTI-layout cloud, one with a cameras.txt, KITTI's calib_velo_to_cam.txt and a
// nuScenes-layout cloud. For the reader's test, `data check`/`convert` and training.
#include <ATen/ATen.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "driving_files.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/io/image.h"

namespace omnipoint::test {

inline const char* const kRigLogPinhole = "PINHOLE 32 24 30 30 16.5 11.25";
inline const char* const kRigLogFisheye = "OPENCV_FISHEYE 40 40 18 18 20 20 0.01 -0.002 0 0";

struct RigLogTruth {
  double u, v, distance;  // pixel coordinates (ours: pixel i spans [i, i+1))
};
// The labels of the two frames.
inline const std::vector<RigLogTruth> kRigLogPinholeTruth = {
    {3.25, 4.75, 6.0}, {20.75, 10.25, 11.5}, {31.5, 23.5, 4.0}};
inline const std::vector<RigLogTruth> kRigLogFisheyeTruth = {
    {2.25, 20.75, 3.0}, {20.25, 20.25, 8.5}, {35.75, 5.25, 5.25}};

// The points of `truth` in the camera frame.
inline at::Tensor rig_log_points(const camera::Camera& camera,
                                 const std::vector<RigLogTruth>& truth) {
  std::vector<double> pixels, distances;
  for (const RigLogTruth& t : truth) {
    pixels.insert(pixels.end(), {t.u, t.v});
    distances.push_back(t.distance);
  }
  const auto n = static_cast<int64_t>(truth.size());
  return camera.unproject(at::tensor(pixels, at::kDouble).view({n, 2})).rays *
         at::tensor(distances, at::kDouble).view({n, 1});
}

// A .bin of `floats` float32 per point (x, y, z, then padding values).
inline void write_lidar_bin(const std::filesystem::path& path, const at::Tensor& points,
                            int64_t floats) {
  const at::Tensor records =
      at::cat({points.to(at::kFloat), at::full({points.size(0), floats - 3}, 7.0f)}, 1)
          .contiguous();
  std::filesystem::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary)
      .write(static_cast<const char*>(records.data_ptr()), records.numel() * sizeof(float));
}

// Writes the two frames and ROOT/manifest.jsonl; returns frame 1's inline lidar_to_camera
// (the row-major 4x4's 16 numbers, comma-separated) for further manifests.
inline std::string write_rig_log(const std::filesystem::path& root) {
  namespace fs = std::filesystem;
  fs::create_directories(root / "front");
  fs::create_directories(root / "side");
  // Frame 1: the camera inline, a KITTI-layout .bin, the transform inline (row-major 4x4).
  const camera::Camera pinhole = camera::parse_camera(kRigLogPinhole);
  const at::Tensor lidar_from_camera =
      rigid(rotation(0.0, 0.6, 0.8, 0.7), at::tensor({0.3, -1.2, 0.5}, at::kDouble));
  write_lidar_bin(root / "lidar" / "a.bin",
                  transformed(lidar_from_camera, rig_log_points(pinhole, kRigLogPinholeTruth)), 4);
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
  const camera::Camera fisheye = camera::parse_camera(kRigLogFisheye);
  const at::Tensor velo_rotation = rotation(1.0, 0.0, 0.0, -1.5);
  const at::Tensor velo_translation = at::tensor({0.1, 0.2, -0.3}, at::kDouble);
  write_text(root / "calib_velo_to_cam.txt",
             "calib_time: 15-Mar-2012 11:37:16\nR: " + kitti_numbers(velo_rotation) +
                 "\nT: " + kitti_numbers(velo_translation) + "\n");
  write_text(root / "side" / "cameras.txt", camera::to_cameras_txt(fisheye));
  write_lidar_bin(root / "lidar" / "b.bin",
                  transformed(at::inverse(rigid(velo_rotation, velo_translation)),
                              rig_log_points(fisheye, kRigLogFisheyeTruth)),
                  5);
  io::write_image_png((root / "side" / "b.png").string(), at::zeros({40, 40, 3}, at::kByte));
  write_text(root / "manifest.jsonl",
             std::string("{\"image\": \"front/a.png\", \"camera\": \"") + kRigLogPinhole +
                 "\", \"lidar\": \"lidar/a.bin\", \"lidar_to_camera\": [" + matrix +
                 "]}\n\n{\"image\": \"side/b.png\", \"camera\": \"side/cameras.txt\", "
                 "\"lidar\": \"lidar/b.bin\", \"lidar_to_camera\": \"calib_velo_to_cam.txt\", "
                 "\"lidar_format\": \"nuscenes\"}\n");
  return matrix;
}

}  // namespace omnipoint::test
