#pragma once
// Reading the user's sparse depth files (the `--sparse-depth` inputs of `omnipoint predict`):
//   *.png           16-bit (or 8-bit) grey depth image in millimetres, planar depth z
//   *.npy           (H, W) float depth in metres, planar depth z
//   *.exr           32-bit float depth in metres (only where OpenCV's EXR codec is enabled)
//   *.ply           point cloud in metres (x, y, z; other properties ignored)
//   *.bin           KITTI Velodyne scan: float32 records x, y, z, intensity, in metres
// Zero (or non-finite) depth means "no sample". Point clouds are in the LiDAR frame; the
// camera-from-LiDAR transform is a 4x4 matrix file: 16 numbers (whitespace or commas,
// row-major; a KITTI-style 3x4 "R|t" with 12 numbers is accepted too) or a .npy.
// Errors: std::runtime_error for unreadable files, std::invalid_argument for content that
// is not what the format promises; each names the file.
#include <ATen/core/Tensor.h>

#include <string>

#include "omnipoint/io/point_cloud.h"
#include "omnipoint/predict/predictor.h"

namespace omnipoint::predict {

SparseDepthInput read_sparse_depth(const std::string& path,
                                   const std::string& camera_from_lidar_path = "");

// The LiDAR file readers live in io (io/point_cloud.h): the (4, 4) float64 camera-from-LiDAR
// transform and a KITTI .bin scan as (N, 3) float32 points.
using io::read_kitti_bin;
using io::read_rigid_transform;

}  // namespace omnipoint::predict
