#pragma once
// A camera rig (io/rig.h) rendered in a procedural scene: every camera of the rig at its pose on
// the body (world_from_camera = world_from_body · body_from_camera), and optionally the sweep of
// a rotating LiDAR at the rig's body_from_lidar, so that `predict --rig` and its scores have
// ground truth (`omnipoint synth --rig`, docs/RIG.md).
//
// The body stands at the scene's viewpoint (Scene::pose, where a single-camera sample of the
// scene would look from), turned by `yaw` about the scene's up axis. Its axes are either the
// scene camera's (BodyAxes::kCamera: x right, y down, z forward, docs/DESIGN.md) or a vehicle's
// (kVehicle: x forward, y left, z up, as KITTI's Velodyne and nuScenes' ego frame), so rigs of
// either kind look at the scene rather than at the floor. The LiDAR fires its beams
// (kitti_raw_drive.h's pattern: elevations about its own z, a full revolution of azimuths) from
// its pose; a beam without a surface within the range returns nothing.
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "omnipoint/data/synth/scene.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/io/rig.h"

namespace omnipoint::data::synth {

enum class BodyAxes { kCamera, kVehicle };
// "camera" | "vehicle"; std::invalid_argument naming the choices otherwise.
BodyAxes parse_body_axes(const std::string& name);

struct RigRenderOptions {
  BodyAxes body_axes = BodyAxes::kCamera;  // how the body's axes sit on the scene's viewpoint
  double yaw = 0;                          // radians, the body turned about the scene's up axis
  SynthOptions synth;                      // the cameras' render settings
  bool lidar = false;                      // cast the rig's LiDAR (the rig must have one)
  geometry::LidarPattern lidar_pattern;    // its beams
  double lidar_range = 120.0;              // metres: farther surfaces return nothing

  // std::invalid_argument, one line, for a pattern or range no LiDAR has.
  void Check() const;
};

// One camera's render.
struct RigCameraRender {
  std::string name;
  // The camera's sample (its camera, image, distance, mask, depth, rays, normals; the scene at
  // the camera's pose; sample.world_from_camera set).
  SynthSample synth;
  at::Tensor body_points;  // (H, W, 3) float64: the surface in the body frame, 0 where no mask
};

struct RigRender {
  at::Tensor world_from_body;            // (4, 4) float64
  std::vector<RigCameraRender> cameras;  // in the rig's order
  at::Tensor lidar_points;  // (N, 3) float64 returns in the LiDAR's frame; undefined: no LiDAR
};

// The body's pose at the scene's viewpoint (see the top).
at::Tensor world_from_body(const Scene& scene, BodyAxes axes, double yaw);

// Renders every camera of `rig` (and its LiDAR when options.lidar) in `scene` with the body at
// `world_from_body`. std::invalid_argument for options.lidar on a rig without a LiDAR.
RigRender render_rig(const Scene& scene, const io::Rig& rig, const at::Tensor& world_from_body,
                     const RigRenderOptions& options = {});

// A sweep as KITTI's velodyne .bin: float32 x, y, z, reflectance (0.5) per point; written
// atomically. `floats_per_point` (the rig's lidar format) must be >= 3; the floats past x, y, z
// are 0.5 (reflectance) then 0 (e.g. nuScenes' ring index).
void write_lidar_sweep(const std::string& path, const at::Tensor& points, int64_t floats_per_point);

// A set of rendered rig frames (`omnipoint synth --rig`): frame k is the scene of seed + k
// with the body at its viewpoint, or with `path` (`synth --rig --path`, the rig's video) the one
// scene of seed with the body moving along a camera path from its viewpoint (camera_path.h:
// camera_path_pose(viewpoint, k, path_step, path_yaw_deg), then the body's axes and yaw as
// above), written under OUT as
//   rig.json                         the rig (io::write_rig: the cameras as spec strings)
//   frames/<frame>/<camera>.png      what `predict --rig OUT/rig.json OUT/frames` reads
//   frames/<frame>/lidar.bin         the sweep (with lidar), in the rig's lidar format
//   truth/<frame>/<camera>/          the camera's ground truth: a synth sample folder
//                                    (synthesize.h: distance.npy, mask.png, depth.npy, rays.npy,
//                                    normals.npy, meta.json with the camera's world pose)
// Frames are named %06d. Each frame's truth folder, then its frames folder, is written staged
// (io::StagedFolder): a frames folder that exists is whole and has its truth, so a rerun keeps
// the frames that exist and renders the others.
struct RigFramesOptions {
  std::string rig;                       // the rig file (io::read_rig)
  SceneKind scene = SceneKind::kIndoor;  // the scenes' kind
  std::uint64_t seed = 0;                // frame k renders the scene of seed + k
  int64_t frames = 1;                    // how many
  RigRenderOptions render;               // the body's axes and yaw, render settings, LiDAR
  bool path = false;                     // one scene, the body moving (see above)
  double path_step = 0.05;               // with path: metres per frame along the view
  double path_yaw_deg = 1.0;             // with path: degrees per frame, turning left

  // std::invalid_argument, one line naming the option, for a value out of range.
  void Check() const;
};

struct RigFramesSummary {
  std::vector<std::string> frames;  // every frame's name, in order
  int64_t rendered = 0;             // frames written by this call
  int64_t kept = 0;                 // frames that were there already
  int64_t lidar_points = 0;         // returns written, all sweeps
};

// Writes the set (see above). `written` (may be empty) is called with each frame's folder as it
// is written. std::invalid_argument for bad options or rig; std::runtime_error when a file cannot
// be written.
RigFramesSummary write_rig_frames(const std::string& out, const RigFramesOptions& options,
                                  const std::function<void(const std::string&)>& written = {});

}  // namespace omnipoint::data::synth
