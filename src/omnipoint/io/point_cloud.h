#pragma once
// LiDAR inputs of `omnipoint predict --sparse-depth` (formats in predict/inputs.h): KITTI
// Velodyne scans and the camera-from-LiDAR transform file. Content that is not what the format
// promises raises std::invalid_argument, an unreadable file std::runtime_error; each names the
// file (`name` for the byte/text-level parsers).
#include <ATen/core/Tensor.h>

#include <string>

namespace omnipoint::io {

// KITTI .bin scan (float32 x, y, z, intensity records) as (N, 3) float32 points (intensity
// dropped).
at::Tensor parse_kitti_bin(const std::string& bytes, const std::string& name);
at::Tensor read_kitti_bin(const std::string& path);

// (4, 4) float64 camera-from-LiDAR transform from text: 16 numbers (4x4) or 12 (a KITTI-style
// 3x4 "R|t"), row-major, separated by whitespace or commas; the matrix must be finite.
at::Tensor parse_rigid_transform(const std::string& text, const std::string& name);
// The same from a file: a .npy holding a (4, 4) or (3, 4) matrix, else text as above.
at::Tensor read_rigid_transform(const std::string& path);

}  // namespace omnipoint::io
