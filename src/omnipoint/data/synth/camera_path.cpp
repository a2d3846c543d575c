#include "omnipoint/data/synth/camera_path.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/staged_folder.h"

namespace omnipoint::data::synth {

namespace {

namespace fs = std::filesystem;

std::string frame_name(int64_t index) {
  char name[32];
  std::snprintf(name, sizeof name, "%06lld", static_cast<long long>(index));
  return name;
}

}  // namespace

Pose camera_path_pose(const Pose& start, int64_t index, double step, double yaw_step_deg) {
  // The viewing direction on the ground plane: the camera's +z in the world, made level.
  const double forward_x = start.rotation[0][2], forward_y = start.rotation[1][2];
  const double heading = std::atan2(forward_y, forward_x);
  const double travelled = step * static_cast<double>(index);
  return make_pose({start.position[0] + travelled * std::cos(heading),
                    start.position[1] + travelled * std::sin(heading), start.position[2]},
                   start.yaw + yaw_step_deg * M_PI / 180.0 * static_cast<double>(index),
                   start.pitch, start.roll);
}

void check_path_motion(double step, double yaw_step_deg) {
  if (!std::isfinite(step) || std::abs(step) > 10)
    throw std::invalid_argument("--path-step: expected metres per frame in [-10, 10]");
  if (!std::isfinite(yaw_step_deg) || std::abs(yaw_step_deg) > 45)
    throw std::invalid_argument("--path-yaw: expected degrees per frame in [-45, 45]");
}

void CameraPathOptions::Check() const {
  if (frames < 2 || frames > 999999)
    throw std::invalid_argument("--count: a camera path has 2 to 999999 frames");
  check_path_motion(step, yaw_step_deg);
}

std::vector<std::string> write_camera_path(const std::string& root,
                                           const CameraPathOptions& options) {
  options.Check();
  if (fs::exists(root) && !(fs::is_directory(root) && fs::is_empty(root)))
    throw std::invalid_argument(root +
                                ": exists and is not an empty folder (a camera path is written "
                                "whole)");
  io::StagedFolder staged{fs::path(root)};
  fs::create_directories(staged.path() / "frames");
  const Scene scene = make_scene(options.scene, options.seed);
  std::vector<std::string> names;
  for (int64_t i = 0; i < options.frames; ++i) {
    Scene moved = scene;
    moved.pose = camera_path_pose(scene.pose, i, options.step, options.yaw_step_deg);
    const SynthSample sample = render_sample(std::move(moved), options.camera, options.synth);
    const std::string name = frame_name(i);
    io::write_image_png((staged.path() / "frames" / (name + ".png")).string(), sample.sample.image);
    write_synth_sample((staged.path() / "truth" / name).string(), sample);
    names.push_back(name);
  }
  staged.commit();
  return names;
}

std::vector<CameraPathFrame> read_camera_path(const std::string& root) {
  const fs::path truth = fs::path(root) / "truth";
  if (!fs::is_directory(truth))
    throw std::invalid_argument(root +
                                ": not a camera path (no truth/ folder; `omnipoint synth "
                                "--path` writes one)");
  std::vector<CameraPathFrame> frames;
  for (const auto& entry : fs::directory_iterator(truth))
    if (entry.is_directory())
      frames.push_back({entry.path().filename().string(), entry.path().string(), {}});
  std::sort(frames.begin(), frames.end(),
            [](const CameraPathFrame& a, const CameraPathFrame& b) { return a.name < b.name; });
  for (CameraPathFrame& frame : frames) frame.world_from_camera = read_sample_pose(frame.truth);
  if (frames.size() < 2)
    throw std::invalid_argument(root + ": a camera path has at least 2 frames in truth/");
  return frames;
}

at::Tensor read_sample_pose(const std::string& folder) {
  const std::string meta = (fs::path(folder) / "meta.json").string();
  try {
    const nlohmann::json pose = nlohmann::json::parse(io::read_file(meta)).at("pose");
    at::Tensor matrix = at::eye(4, at::kDouble);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) matrix[r][c] = pose.at("rotation").at(r).at(c).get<double>();
      matrix[r][3] = pose.at("position").at(r).get<double>();
    }
    return matrix;
  } catch (const nlohmann::json::exception& e) {
    throw std::invalid_argument(meta +
                                ": no camera pose (\"pose\": rotation, position): " + e.what());
  }
}

}  // namespace omnipoint::data::synth
