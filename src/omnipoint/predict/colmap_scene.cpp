#include "omnipoint/predict/colmap_scene.h"

#include <ATen/ATen.h>

#include <filesystem>
#include <stdexcept>

namespace omnipoint::predict {

ColmapScene ColmapScene::read(const std::string& sparse_folder) {
  return ColmapScene(io::read_colmap_model(sparse_folder));
}

ColmapScene::ColmapScene(const io::ColmapModel& model) {
  for (const io::ColmapImage& image : model.images) {
    std::vector<double> xyz;
    for (const int64_t id : image.point3d_ids) {
      if (id < 0) continue;
      const auto point = model.points.find(id);
      if (point == model.points.end()) continue;  // a track COLMAP filtered out
      xyz.insert(xyz.end(), point->second.xyz.begin(), point->second.xyz.end());
    }
    const int64_t observed = static_cast<int64_t>(xyz.size()) / 3;
    views_.push_back(ColmapView{image.name, model.cameras.at(image.camera_id),
                                io::camera_from_world(image),
                                at::tensor(xyz, at::kDouble).view({observed, 3})});
    by_name_[image.name] = views_.size() - 1;
    by_file_name_[std::filesystem::path(image.name).filename().string()].push_back(views_.size() -
                                                                                   1);
  }
}

const ColmapView* ColmapScene::find(const std::string& relative_path) const {
  const std::string name = std::filesystem::path(relative_path).generic_string();
  if (const auto exact = by_name_.find(name); exact != by_name_.end())
    return &views_[exact->second];
  const auto same_file = by_file_name_.find(std::filesystem::path(name).filename().string());
  if (same_file != by_file_name_.end() && same_file->second.size() == 1)
    return &views_[same_file->second.front()];
  return nullptr;
}

SparseDepthInput sparse_depth_of(const ColmapView& view) {
  SparseDepthInput input;
  input.lidar_points = view.observed_points.to(at::kFloat);
  input.camera_from_lidar = view.camera_from_world;
  return input;
}

at::Tensor world_points(const at::Tensor& camera_points, const at::Tensor& camera_from_world) {
  if (camera_from_world.sizes() != at::IntArrayRef{4, 4} || camera_points.size(-1) != 3)
    throw std::invalid_argument("world_points: expected points (..., 3) and a (4, 4) pose");
  // X = R^T (P - t) for P = R X + t.
  const at::Tensor pose = camera_from_world.to(at::kDouble);
  const at::Tensor rotation = pose.slice(0, 0, 3).slice(1, 0, 3);
  const at::Tensor translation = pose.slice(0, 0, 3).select(1, 3);
  return (camera_points.to(at::kDouble) - translation).matmul(rotation).to(at::kFloat);
}

}  // namespace omnipoint::predict
