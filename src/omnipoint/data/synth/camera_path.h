#pragma once
// A short camera path through one synthetic scene (`omnipoint synth --path`): the scene of
// (kind, seed) rendered from `frames` poses that start at the scene's own camera pose and move
// `step` metres per frame along its horizontal viewing direction while turning `yaw_step_deg`
// about the vertical, so consecutive frames see the same static scene from known poses. The
// root holds
//   frames/NNNNNN.png   the images, in name order: the FRAMES of `predict --sequence`
//   truth/NNNNNN/       each frame's synthetic sample (synthesize.h: image, metric distance,
//                       mask, depth, rays, normals, the camera; meta.json's "pose" is the
//                       frame's camera-to-world pose, X_world = rotation X_camera + position)
// and is written whole or not at all (a staging folder renamed into place).
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/scene.h"
#include "omnipoint/data/synth/synthesize.h"

namespace omnipoint::data::synth {

// Frame `index`'s pose on a camera path from `start`: moved index * step metres along start's
// viewing direction made level, turned index * yaw_step_deg degrees about the vertical (world
// +z, turning left), height, pitch and roll kept. The path of `synth --path`, and of the body of
// `synth --rig --path` (rig_render.h).
Pose camera_path_pose(const Pose& start, int64_t index, double step, double yaw_step_deg);
// std::invalid_argument, one line naming the option, for a step or turn no path takes.
void check_path_motion(double step, double yaw_step_deg);

struct CameraPathOptions {
  camera::Camera camera{"PINHOLE", 128, 96, {80, 80, 64, 48}};  // every frame's
  SceneKind scene = SceneKind::kIndoor;
  std::uint64_t seed = 0;     // the scene's
  int64_t frames = 8;         // poses along the path
  double step = 0.05;         // metres per frame, forward
  double yaw_step_deg = 1.0;  // degrees per frame, turning left (about world +z)
  SynthOptions synth;         // the render settings

  // std::invalid_argument, one line naming the option, when no path can be written.
  void Check() const;
};

// Writes the root `root` (a folder that must not exist or be empty). std::invalid_argument for
// bad options or a non-empty root; std::runtime_error when a file cannot be written. Returns the
// frames' names.
std::vector<std::string> write_camera_path(const std::string& root,
                                           const CameraPathOptions& options);

// A written path read back: the frames' truth folders and poses, in frame order.
struct CameraPathFrame {
  std::string name;              // NNNNNN
  std::string truth;             // root/truth/NNNNNN (a sample folder)
  at::Tensor world_from_camera;  // (4, 4) float64
};
// std::invalid_argument naming the file for a root that is not a camera path.
std::vector<CameraPathFrame> read_camera_path(const std::string& root);

// The camera-to-world pose (4, 4) float64 of a synthetic sample folder (its meta.json's
// "pose": rotation, position), as camera paths and rendered rigs write it.
// std::invalid_argument naming the file when it has none.
at::Tensor read_sample_pose(const std::string& folder);

}  // namespace omnipoint::data::synth
