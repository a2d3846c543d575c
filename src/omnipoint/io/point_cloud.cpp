#include "omnipoint/io/point_cloud.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/file_name.h"
#include "omnipoint/io/npy.h"

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

}  // namespace

at::Tensor parse_kitti_bin(const std::string& bytes, const std::string& name) {
  constexpr size_t kRecord = 4 * sizeof(float);
  if (bytes.empty() || bytes.size() % kRecord != 0)
    throw std::invalid_argument("sparse depth " + name +
                                ": a KITTI .bin holds float32 x, y, z, intensity records (" +
                                std::to_string(bytes.size()) + " bytes is not a multiple of 16)");
  const int64_t count = static_cast<int64_t>(bytes.size() / kRecord);
  at::Tensor records = at::empty({count, 4}, at::kFloat);
  std::memcpy(records.data_ptr<float>(), bytes.data(), bytes.size());
  return records.slice(1, 0, 3).contiguous();
}

at::Tensor read_kitti_bin(const std::string& path) {
  return parse_kitti_bin(read_file(path), path);
}

at::Tensor parse_rigid_transform(const std::string& text, const std::string& name) {
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
