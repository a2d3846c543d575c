// Sparse depth files -> SparseDepthInput (formats in inputs.h).
#include "omnipoint/predict/inputs.h"

#include <ATen/ATen.h>

#include <filesystem>
#include <stdexcept>

#include "omnipoint/io/file_name.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"

namespace omnipoint::predict {

namespace {

at::Tensor finite_points(const at::Tensor& points, const std::string& path) {
  if (points.dim() != 2 || points.size(1) != 3 || points.size(0) == 0)
    throw std::invalid_argument("sparse depth " + path + ": expected a non-empty point cloud");
  return points.to(at::kFloat);
}

}  // namespace

SparseDepthInput read_sparse_depth(const std::string& path,
                                   const std::string& camera_from_lidar_path) {
  if (!std::filesystem::is_regular_file(path))
    throw std::runtime_error("sparse depth " + path + ": no such file");
  const std::string ext = io::lower_extension(path);
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
