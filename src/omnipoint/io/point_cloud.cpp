#include "omnipoint/io/point_cloud.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <charconv>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/file_name.h"
#include "omnipoint/io/keyed_text.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/pcd.h"
#include "omnipoint/io/ply.h"

namespace omnipoint::io {
namespace {

// 3x4 -> 4x4 with the row (0, 0, 0, 1); then the matrix must be a finite 4x4.
at::Tensor checked_transform(at::Tensor matrix, const std::string& name) {
  if (matrix.dim() == 2 && matrix.size(0) == 3 && matrix.size(1) == 4)
    matrix = at::cat({matrix, at::tensor({0.0, 0.0, 0.0, 1.0}, at::kDouble).view({1, 4})});
  if (matrix.dim() != 2 || matrix.size(0) != 4 || matrix.size(1) != 4 ||
      !at::isfinite(matrix).all().item<bool>())
    throw std::invalid_argument("camera-from-LiDAR " + name +
                                ": expected a finite 4x4 (or 3x4) matrix");
  return matrix;
}

// Counts of floats per point the layout option accepts (lidar_floats_per_point).
constexpr int64_t kMaxFloatsPerPoint = 1024;

// For a .bin of `size` bytes that is no whole number of records: the layouts it would fit,
// as "; would fit: --lidar-format nuscenes (20 bytes per point)", float counts 3..8.
std::string layouts_fitting(size_t size) {
  std::string fitting;
  for (int64_t floats = 3; floats <= 8; ++floats) {
    if (size % (floats * sizeof(float)) != 0) continue;
    const std::string layout = floats == 4   ? "kitti"
                               : floats == 5 ? "nuscenes"
                                             : std::to_string(floats);
    fitting += (fitting.empty() ? "" : ", ") + ("--lidar-format " + layout) + " (" +
               std::to_string(floats * sizeof(float)) + " bytes per point)";
  }
  return fitting.empty() ? "" : "; would fit: " + fitting;
}

// The numbers of a plain matrix file, separated by whitespace or commas.
std::vector<double> numbers_in(const std::string& text, const std::string& name) {
  std::string spaced = text;
  std::replace(spaced.begin(), spaced.end(), ',', ' ');
  std::istringstream stream(spaced);
  std::vector<double> values;
  std::string token;
  while (stream >> token) {
    try {
      size_t used = 0;
      values.push_back(std::stod(token, &used));
      if (used != token.size()) throw std::invalid_argument(token);
    } catch (const std::exception&) {
      throw std::invalid_argument("camera-from-LiDAR " + name + ": \"" + token +
                                  "\" is not a number");
    }
  }
  return values;
}

// Whether the text is a KITTI calibration file: lines "KEY: values" rather than bare numbers.
bool is_keyed(const std::string& text) {
  std::istringstream stream(text);
  std::string first;
  stream >> first;
  return !first.empty() && first.back() == ':';
}

// The transform of a KITTI calibration file: "Tr: 12 numbers" (odometry) or "R: 9" and
// "T: 3" (raw); every other key is ignored.
at::Tensor keyed_transform(const std::string& text, const std::string& name) {
  const KeyedText keyed = KeyedText::parse(text, "camera-from-LiDAR " + name);
  const auto numbers = [&](const std::string& key, size_t count) {
    return at::tensor(keyed.numbers(key, count), at::kDouble);
  };
  if (keyed.has("Tr")) return numbers("Tr", 12).view({3, 4});
  if (keyed.has("R") && keyed.has("T"))
    return at::cat({numbers("R", 9).view({3, 3}), numbers("T", 3).view({3, 1})}, 1);
  std::string found;
  for (const std::string& key : keyed.keys()) found += (found.empty() ? "" : ", ") + key;
  const std::string missing = keyed.has("R") ? "T" : keyed.has("T") ? "R" : "R and T";
  throw std::invalid_argument("camera-from-LiDAR " + name + ": a KITTI calibration file needs " +
                              missing +
                              " (raw calib_velo_to_cam.txt) or Tr (odometry calib.txt); "
                              "found " +
                              found);
}

}  // namespace

int64_t lidar_floats_per_point(const std::string& format) {
  if (format == "kitti") return 4;
  if (format == "nuscenes") return 5;
  int64_t count = 0;
  const char* end = format.data() + format.size();
  const auto [stop, error] = std::from_chars(format.data(), end, count);
  if (error != std::errc() || stop != end || count < 3 || count > kMaxFloatsPerPoint)
    throw std::invalid_argument("LiDAR format '" + format +
                                "': expected kitti (4 floats per point), nuscenes (5) or a "
                                "float count 3.." +
                                std::to_string(kMaxFloatsPerPoint));
  return count;
}

at::Tensor parse_lidar_bin(const std::string& bytes, const std::string& name,
                           int64_t floats_per_point) {
  if (floats_per_point < 3 || floats_per_point > kMaxFloatsPerPoint)
    throw std::invalid_argument("sparse depth " + name + ": " + std::to_string(floats_per_point) +
                                " floats per point (expected 3.." +
                                std::to_string(kMaxFloatsPerPoint) + ")");
  const size_t record = static_cast<size_t>(floats_per_point) * sizeof(float);
  if (bytes.empty())
    throw std::invalid_argument("sparse depth " + name + ": the .bin scan is empty (0 bytes)");
  if (bytes.size() % record != 0)
    throw std::invalid_argument("sparse depth " + name + ": " + std::to_string(bytes.size()) +
                                " bytes is not a multiple of " + std::to_string(record) + " (" +
                                std::to_string(floats_per_point) +
                                " float32 per point, x, y, z first)" +
                                layouts_fitting(bytes.size()));
  const int64_t count = static_cast<int64_t>(bytes.size() / record);
  at::Tensor records = at::empty({count, floats_per_point}, at::kFloat);
  std::memcpy(records.data_ptr<float>(), bytes.data(), bytes.size());
  return records.slice(1, 0, 3).contiguous();
}

at::Tensor read_lidar_bin(const std::string& path, int64_t floats_per_point) {
  return parse_lidar_bin(read_file(path), path, floats_per_point);
}

at::Tensor read_kitti_bin(const std::string& path) {
  return read_lidar_bin(path, 4);
}

bool is_point_cloud_file(const std::string& path) {
  const std::string ext = lower_extension(path);
  return ext == ".ply" || ext == ".pcd" || ext == ".bin";
}

at::Tensor read_point_cloud(const std::string& path, int64_t floats_per_point,
                            const std::string& what) {
  const std::string ext = lower_extension(path);
  const at::Tensor points = ext == ".ply"   ? read_ply(path).points
                            : ext == ".pcd" ? read_pcd(path)
                                            : read_lidar_bin(path, floats_per_point);
  if (points.dim() != 2 || points.size(1) != 3 || points.size(0) == 0)
    throw std::invalid_argument(what + " " + path + ": expected a non-empty point cloud");
  return points.to(at::kFloat);
}

at::Tensor parse_rigid_transform(const std::string& text, const std::string& name) {
  if (is_keyed(text)) return checked_transform(keyed_transform(text, name), name);
  const std::vector<double> values = numbers_in(text, name);
  if (values.size() != 12 && values.size() != 16)
    throw std::invalid_argument("camera-from-LiDAR " + name +
                                ": expected 16 numbers (4x4) or 12 (3x4), got " +
                                std::to_string(values.size()));
  return checked_transform(at::tensor(values, at::kDouble).view({-1, 4}), name);
}

at::Tensor read_rigid_transform(const std::string& path) {
  if (lower_extension(path) == ".npy")
    return checked_transform(read_npy(path).to(at::kDouble), path);
  return parse_rigid_transform(read_file(path), path);
}

}  // namespace omnipoint::io
