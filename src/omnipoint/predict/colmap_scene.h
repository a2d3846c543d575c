#pragma once
// A COLMAP sparse reconstruction as predict's input (`omnipoint predict IMAGES --colmap SPARSE`):
// each registered image brings its camera, its pose and, as sparse depth, the reconstruction's
// 3-D points it observes, taken into its camera frame through its pose. Predictions are then
// aligned to those points, so they come out in the reconstruction's units — COLMAP's scale is
// arbitrary (a monocular reconstruction has no metres) — and, moved by the inverse pose, lie in
// its world frame on top of the sparse model.
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/io/colmap.h"
#include "omnipoint/predict/predictor.h"

namespace omnipoint::predict {

struct ColmapView {
  std::string name;              // as images.txt has it: the path below the image folder
  camera::Camera camera;         // at the size COLMAP saw the image
  at::Tensor camera_from_world;  // (4, 4) float64
  at::Tensor observed_points;    // (N, 3) float64 world points of the image's observations
};

class ColmapScene {
 public:
  // Reads the model folder (io::read_colmap_model); errors name the folder or file.
  static ColmapScene read(const std::string& sparse_folder);
  explicit ColmapScene(const io::ColmapModel& model);

  // The view of an image given by its path below the image folder ("a/b.jpg"); else by its file
  // name when exactly one view has it. nullptr when none (the image is not registered).
  const ColmapView* find(const std::string& relative_path) const;
  const std::vector<ColmapView>& views() const { return views_; }

 private:
  std::vector<ColmapView> views_;
  std::map<std::string, size_t> by_name_;
  std::map<std::string, std::vector<size_t>> by_file_name_;
};

// The view's observed points as predict's sparse depth (a point cloud in the world frame with
// the camera-from-world transform).
SparseDepthInput sparse_depth_of(const ColmapView& view);

// Camera-frame points (..., 3) into the world frame of camera_from_world (4, 4); float32 out.
at::Tensor world_points(const at::Tensor& camera_points, const at::Tensor& camera_from_world);

}  // namespace omnipoint::predict
