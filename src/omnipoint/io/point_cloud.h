#pragma once
// LiDAR inputs of `omnipoint predict --sparse-depth` (formats in predict/inputs.h): raw
// float32 scans (.bin) and the camera-from-LiDAR transform file. Content that is not what the
// format promises raises std::invalid_argument, an unreadable file std::runtime_error; each
// names the file (`name` for the byte/text-level parsers).
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>

namespace omnipoint::io {

// The float32 count of one point of a .bin layout: "kitti" (x, y, z, intensity) = 4,
// "nuscenes" (x, y, z, intensity, ring index) = 5, or a count 3..1024 written as a number.
// Anything else raises std::invalid_argument listing these.
int64_t lidar_floats_per_point(const std::string& format);

// A .bin scan of little-endian float32 records of `floats_per_point` values, x, y, z first, as
// (N, 3) float32 points (the other values dropped). A size that is not a whole number of
// records raises std::invalid_argument naming the layouts the size would fit.
at::Tensor parse_lidar_bin(const std::string& bytes, const std::string& name,
                           int64_t floats_per_point);
at::Tensor read_lidar_bin(const std::string& path, int64_t floats_per_point);
// The KITTI layout (4 floats per point).
at::Tensor read_kitti_bin(const std::string& path);

// Whether `path` names a point cloud by its extension: .ply, .pcd or a .bin scan.
bool is_point_cloud_file(const std::string& path);
// A point cloud file as (N, 3) float32 points (x, y, z; other properties dropped): .ply
// (io/ply.h), .pcd (io/pcd.h) or a .bin scan of `floats_per_point` float32 per point. An empty
// cloud raises std::invalid_argument naming the file (`what` in front: "sparse depth", ...).
at::Tensor read_point_cloud(const std::string& path, int64_t floats_per_point,
                            const std::string& what = "point cloud");

// (4, 4) float64 camera-from-LiDAR transform from text, in one of these forms:
// - 16 numbers (4x4) or 12 (a 3x4 "R|t"), row-major, separated by whitespace or commas;
// - KITTI raw `calib_velo_to_cam.txt`: lines `R: 9 numbers` and `T: 3 numbers` (other keyed
//   lines such as calib_time, delta_f, delta_c are ignored). The result maps Velodyne points
//   into the unrectified frame of KITTI's reference camera 0;
// - KITTI odometry `calib.txt`: the line `Tr: 12 numbers` (P0..P3 are ignored), which maps
//   Velodyne points into the rectified frame of camera 0.
// Neither holds the chain to another camera (KITTI's colour images are camera 2): the
// rectification R_rect_00 and the camera's offset inside P_rect_02 are not applied. Compose
// it and pass the 4x4 as 16 numbers: camera2_from_velo = [I | K2^-1 P2[:, 3]] * R_rect_00 *
// [R | T] with P2 = P_rect_02 = [K2 | P2[:, 3]] and R_rect_00 (as a 4x4) from
// calib_cam_to_cam.txt; for odometry [I | K2^-1 P2[:, 3]] * Tr with P2 from calib.txt.
// A keyed file without R and T or Tr raises std::invalid_argument naming the missing keys.
// The matrix must be finite.
at::Tensor parse_rigid_transform(const std::string& text, const std::string& name);
// The same from a file: a .npy holding a (4, 4) or (3, 4) matrix, else text as above.
at::Tensor read_rigid_transform(const std::string& path);

}  // namespace omnipoint::io
