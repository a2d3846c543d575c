// Sparse depth files -> SparseDepthInput (formats in inputs.h).
#include "omnipoint/predict/inputs.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"

namespace omnipoint::predict {

namespace {

std::string extension_of(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext;
}

at::Tensor finite_points(const at::Tensor& points, const std::string& path) {
  if (points.dim() != 2 || points.size(1) != 3 || points.size(0) == 0)
    throw std::invalid_argument("sparse depth " + path + ": expected a non-empty point cloud");
  return points.to(at::kFloat);
}

}  // namespace

at::Tensor read_kitti_bin(const std::string& path) {
  const std::string bytes = io::read_file(path);
  constexpr size_t kRecord = 4 * sizeof(float);
  if (bytes.empty() || bytes.size() % kRecord != 0)
    throw std::invalid_argument("sparse depth " + path +
                                ": a KITTI .bin holds float32 x, y, z, intensity records (" +
                                std::to_string(bytes.size()) + " bytes is not a multiple of 16)");
  const int64_t count = static_cast<int64_t>(bytes.size() / kRecord);
  at::Tensor records = at::empty({count, 4}, at::kFloat);
  std::memcpy(records.data_ptr<float>(), bytes.data(), bytes.size());
  return records.slice(1, 0, 3).contiguous();
}

at::Tensor read_rigid_transform(const std::string& path) {
  at::Tensor matrix;
  if (extension_of(path) == ".npy") {
    matrix = io::read_npy(path).to(at::kDouble);
  } else {
    std::string text = io::read_file(path);
    std::replace(text.begin(), text.end(), ',', ' ');
    std::istringstream stream(text);
    std::vector<double> values;
    std::string token;
    while (stream >> token) {
      try {
        size_t used = 0;
        values.push_back(std::stod(token, &used));
        if (used != token.size()) throw std::invalid_argument(token);
      } catch (const std::exception&) {
        throw std::invalid_argument("camera-from-LiDAR " + path + ": \"" + token +
                                    "\" is not a number");
      }
    }
    if (values.size() != 12 && values.size() != 16)
      throw std::invalid_argument("camera-from-LiDAR " + path +
                                  ": expected 16 numbers (4x4) or 12 (3x4), got " +
                                  std::to_string(values.size()));
    matrix = at::tensor(values, at::kDouble).view({-1, 4});
  }
  if (matrix.dim() == 2 && matrix.size(0) == 3 && matrix.size(1) == 4)
    matrix = at::cat({matrix, at::tensor({0.0, 0.0, 0.0, 1.0}, at::kDouble).view({1, 4})});
  if (matrix.dim() != 2 || matrix.size(0) != 4 || matrix.size(1) != 4 ||
      !at::isfinite(matrix).all().item<bool>())
    throw std::invalid_argument("camera-from-LiDAR " + path +
                                ": expected a finite 4x4 (or 3x4) matrix");
  return matrix;
}

SparseDepthInput read_sparse_depth(const std::string& path,
                                   const std::string& camera_from_lidar_path) {
  if (!std::filesystem::is_regular_file(path))
    throw std::runtime_error("sparse depth " + path + ": no such file");
  const std::string ext = extension_of(path);
  SparseDepthInput input;
  if (ext == ".png" || ext == ".exr" || ext == ".npy") {
    if (!camera_from_lidar_path.empty())
      throw std::invalid_argument("sparse depth " + path +
                                  ": --lidar-to-camera applies to point clouds only");
    at::Tensor depth;
    if (ext == ".npy") {
      depth = io::read_npy(path);
      if (!at::isFloatingType(depth.scalar_type()))
        throw std::invalid_argument("sparse depth " + path +
                                    ": expected float depth in metres, got dtype " +
                                    std::string(c10::toString(depth.scalar_type())));
    } else {
      try {
        depth = io::read_image_values(path);
      } catch (const std::runtime_error& e) {
        if (ext != ".exr") throw;
        // OpenCV builds EXR support in but disables it unless OPENCV_IO_ENABLE_OPENEXR is set.
        throw std::runtime_error(
            "sparse depth " + path + ": OpenCV could not decode this EXR (" + e.what() +
            "); its EXR codec is off unless OPENCV_IO_ENABLE_OPENEXR=1 is set, or pass .npy");
      }
      if (ext == ".png") depth = depth / 1000.0;  // millimetres
    }
    if (depth.dim() != 2)
      throw std::invalid_argument("sparse depth " + path +
                                  ": expected a single-channel (H, W) map, got " +
                                  c10::str(depth.sizes()));
    input.depth_map = depth.to(at::kFloat);
    input.depth_is_planar = true;
    return input;
  }
  if (ext == ".ply") {
    input.lidar_points = finite_points(io::read_ply(path).points, path);
  } else if (ext == ".bin") {
    input.lidar_points = read_kitti_bin(path);
  } else {
    throw std::invalid_argument(
        "sparse depth " + path +
        ": unknown format (expected .png in mm, .npy or .exr in metres, .ply or KITTI .bin)");
  }
  if (!camera_from_lidar_path.empty())
    input.camera_from_lidar = read_rigid_transform(camera_from_lidar_path);
  return input;
}

}  // namespace omnipoint::predict
