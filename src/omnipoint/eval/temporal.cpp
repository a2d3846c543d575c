#include "omnipoint/eval/temporal.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <optional>
#include <stdexcept>
#include <string>

#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/camera_path.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/rig.h"

namespace omnipoint::eval {

namespace {

void check_frame(const SequenceFrame& frame, const camera::Camera& camera) {
  const int64_t height = camera.height(), width = camera.width();
  if (frame.points.dim() != 3 || frame.points.size(0) != height || frame.points.size(1) != width ||
      frame.points.size(2) != 3 || frame.mask.sizes() != frame.points.sizes().slice(0, 2) ||
      frame.world_from_camera.dim() != 2 || frame.world_from_camera.size(0) != 4 ||
      frame.world_from_camera.size(1) != 4)
    throw std::invalid_argument("temporal stability: expected points (" + std::to_string(height) +
                                ", " + std::to_string(width) + ", 3), a mask (" +
                                std::to_string(height) + ", " + std::to_string(width) +
                                ") and a (4, 4) pose per frame, as the camera's size");
}

}  // namespace

PairStability temporal_pair_stability(const SequenceFrame& from, const SequenceFrame& to,
                                      const camera::Camera& camera) {
  check_frame(from, camera);
  check_frame(to, camera);
  const int64_t height = camera.height(), width = camera.width();
  const auto f64 = [](const at::Tensor& t) { return t.to(at::kCPU, at::kDouble); };
  const at::Tensor mask_from = from.mask.to(at::kCPU, at::kBool);
  const at::Tensor points = f64(from.points).index({mask_from});  // (N, 3)
  // Frame t's points in frame t+1's camera frame.
  const at::Tensor to_from =
      at::matmul(at::inverse(f64(to.world_from_camera)), f64(from.world_from_camera));
  const at::Tensor carried = at::matmul(points, to_from.slice(0, 0, 3).slice(1, 0, 3).t()) +
                             to_from.slice(0, 0, 3).select(1, 3);
  const camera::Pixels projected = camera.project(carried);
  // Bilinear corners: pixel centres are at i + 0.5.
  const at::Tensor x = projected.pixels.select(-1, 0) - 0.5,
                   y = projected.pixels.select(-1, 1) - 0.5;
  const at::Tensor x0 = at::floor(x), y0 = at::floor(y);
  at::Tensor usable =
      projected.valid & (x0 >= 0) & (y0 >= 0) & (x0 + 1 <= width - 1) & (y0 + 1 <= height - 1);
  const at::Tensor index = usable.nonzero().squeeze(1);
  PairStability pair;
  pair.pixels = 0;
  pair.error = std::numeric_limits<double>::quiet_NaN();
  if (index.numel() == 0) return pair;
  const at::Tensor cx = x0.index_select(0, index).to(at::kLong),
                   cy = y0.index_select(0, index).to(at::kLong);
  const at::Tensor fx = x.index_select(0, index) - x0.index_select(0, index),
                   fy = y.index_select(0, index) - y0.index_select(0, index);
  const at::Tensor distance = at::linalg_vector_norm(f64(to.points), 2, {-1}).reshape({-1});
  const at::Tensor valid_to = to.mask.to(at::kCPU, at::kBool).reshape({-1});
  const auto at_corner = [&](const at::Tensor& dx, const at::Tensor& dy) {
    return (cy + dy) * width + (cx + dx);
  };
  const at::Tensor zero = at::zeros_like(cx), one = at::ones_like(cx);
  const at::Tensor i00 = at_corner(zero, zero), i10 = at_corner(one, zero),
                   i01 = at_corner(zero, one), i11 = at_corner(one, one);
  const at::Tensor corners_valid = valid_to.index_select(0, i00) & valid_to.index_select(0, i10) &
                                   valid_to.index_select(0, i01) & valid_to.index_select(0, i11);
  const at::Tensor sampled = (1 - fx) * (1 - fy) * distance.index_select(0, i00) +
                             fx * (1 - fy) * distance.index_select(0, i10) +
                             (1 - fx) * fy * distance.index_select(0, i01) +
                             fx * fy * distance.index_select(0, i11);
  const at::Tensor carried_distance =
      at::linalg_vector_norm(carried.index_select(0, index), 2, {-1});
  const at::Tensor kept = corners_valid & (carried_distance > 0);
  const at::Tensor relative = ((sampled - carried_distance).abs() / carried_distance).index({kept});
  pair.pixels = relative.numel();
  if (pair.pixels > 0) pair.error = relative.median().item<double>();
  return pair;
}

TemporalStability temporal_stability(const std::vector<SequenceFrame>& frames,
                                     const camera::Camera& camera) {
  TemporalStability stability;
  double sum = 0;
  int64_t scored = 0;
  for (size_t t = 0; t + 1 < frames.size(); ++t) {
    stability.pairs.push_back(temporal_pair_stability(frames[t], frames[t + 1], camera));
    if (stability.pairs.back().pixels == 0) continue;
    sum += stability.pairs.back().error;
    ++scored;
  }
  stability.error =
      scored == 0 ? std::numeric_limits<double>::quiet_NaN() : sum / static_cast<double>(scored);
  return stability;
}

namespace {

// A predicted frame (PREDICTIONS/.../points.npy, valid where non-zero) with its true pose; the
// camera is the first frame's truth camera at the predictions' size.
SequenceFrame read_predicted_frame(const std::filesystem::path& file, const std::string& truth,
                                   const at::Tensor& world_from_camera,
                                   std::optional<camera::Camera>& camera) {
  if (!std::filesystem::is_regular_file(file))
    throw std::invalid_argument(file.string() + ": no predicted points for the frame of " + truth);
  const at::Tensor points = io::read_npy(file.string()).to(at::kFloat);
  if (points.dim() != 3 || points.size(2) != 3)
    throw std::invalid_argument(file.string() + ": expected (H, W, 3) points");
  if (!camera) camera = data::read_sample(truth).camera.resized(points.size(1), points.size(0));
  if (points.size(0) != camera->height() || points.size(1) != camera->width())
    throw std::invalid_argument(file.string() + ": the frames differ in size");
  return {points, (points != 0).any(-1), world_from_camera};
}

}  // namespace

TemporalStability score_predicted_sequence(const std::string& predictions,
                                           const std::string& truth) {
  const std::vector<data::synth::CameraPathFrame> path = data::synth::read_camera_path(truth);
  std::vector<SequenceFrame> frames;
  frames.reserve(path.size());
  std::optional<camera::Camera> camera;
  for (const data::synth::CameraPathFrame& frame : path)
    frames.push_back(
        read_predicted_frame(std::filesystem::path(predictions) / frame.name / "points.npy",
                             frame.truth, frame.world_from_camera, camera));
  return temporal_stability(frames, *camera);
}

bool is_rig_truth(const std::string& truth) {
  return std::filesystem::is_regular_file(std::filesystem::path(truth) / "rig.json");
}

RigTemporalStability score_predicted_rig_sequence(const std::string& predictions,
                                                  const std::string& truth) {
  namespace fs = std::filesystem;
  const io::Rig rig = io::read_rig((fs::path(truth) / "rig.json").string());
  std::vector<std::string> names;  // the frames: truth/<frame>/, in name order
  if (fs::is_directory(fs::path(truth) / "truth"))
    for (const auto& entry : fs::directory_iterator(fs::path(truth) / "truth"))
      if (entry.is_directory() && entry.path().filename().string().front() != '.')
        names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  if (names.size() < 2)
    throw std::invalid_argument(truth +
                                ": a rig's video has at least 2 frames in truth/ (`omnipoint "
                                "synth --rig --path` writes them)");
  RigTemporalStability result;
  double sum = 0;
  int counted = 0;
  for (const io::RigCamera& rig_camera : rig.cameras) {
    std::vector<SequenceFrame> frames;
    std::optional<camera::Camera> camera;
    for (const std::string& name : names) {
      const std::string folder = (fs::path(truth) / "truth" / name / rig_camera.name).string();
      frames.push_back(
          read_predicted_frame(fs::path(predictions) / name / rig_camera.name / "points.npy",
                               folder, data::synth::read_sample_pose(folder), camera));
    }
    TemporalStability stability = temporal_stability(frames, *camera);
    if (std::isfinite(stability.error)) {
      sum += stability.error;
      ++counted;
    }
    result.cameras.emplace_back(rig_camera.name, std::move(stability));
  }
  result.error = counted > 0 ? sum / counted : std::numeric_limits<double>::quiet_NaN();
  return result;
}

}  // namespace omnipoint::eval
