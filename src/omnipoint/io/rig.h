#pragma once
// A rig file: the cameras (and optionally the LiDAR) of one vehicle or robot, each with its
// pose in the rig's body frame (docs/RIG.md).
//   {"frame": "body",
//    "cameras": [{"name": "front", "camera": "PINHOLE 1920 1080 ...",
//                 "body_from_camera": [[r11, r12, r13, t1], [r21, r22, r23, t2],
//                                      [r31, r32, r33, t3]]}, ...],
//    "lidar": {"format": "kitti", "body_from_lidar": [[...], [...], [...]]}}
// `camera` is any --camera form (io::read_camera); a file path is relative to the rig file's
// folder. A transform is 3 rows of 4 numbers (or 4, the last [0, 0, 0, 1]), in metres, taking
// a point in the sensor's frame into the body frame; its rotation must be orthonormal with
// determinant +1 (within kRotationTolerance). `lidar.format` is any --lidar-format
// (io::lidar_floats_per_point). Camera names name folders and files (FRAMES/<frame>/<name>.jpg),
// so they are letters, digits, '_', '-' and '.', not starting with '.'.
#include <ATen/core/Tensor.h>

#include <optional>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"

namespace omnipoint::io {

// Largest |RᵀR − I| entry accepted: calibration files print rotations to about 7 digits.
inline constexpr double kRotationTolerance = 1e-4;

struct RigCamera {
  std::string name;
  camera::Camera camera;
  at::Tensor body_from_camera;  // (4, 4) float64
};

struct RigLidar {
  std::string format;          // as given ("kitti", "nuscenes", a float count)
  int64_t floats_per_point;    // io::lidar_floats_per_point(format)
  at::Tensor body_from_lidar;  // (4, 4) float64
};

struct Rig {
  std::string frame = "body";  // the body frame's name, for the reports
  std::vector<RigCamera> cameras;
  std::optional<RigLidar> lidar;
  // The camera named `name`; nullptr when the rig has none.
  const RigCamera* find(const std::string& name) const;
};

// The rig of a rig file's text; `source` names it in messages and camera file paths are
// relative to `folder`. Bad content -> std::invalid_argument with one line naming the field
// ("rig.json: cameras[1].body_from_camera: ..."); an unreadable camera file ->
// std::runtime_error.
Rig parse_rig(const std::string& text, const std::string& source, const std::string& folder);
// The same from a file (camera paths relative to its folder); unreadable -> std::runtime_error.
Rig read_rig(const std::string& path);

// The rig file's text of `rig`: the keys above, each camera as its spec (to_spec), transforms
// as 3 rows of 4 numbers printed to round-trip precision, so parse_rig reads back exactly
// what was given.
std::string format_rig(const Rig& rig);
// Writes format_rig(rig) to `path` atomically, after reading it back: a rig the reader would
// refuse (a rotation off orthonormal, a bad name) -> its std::invalid_argument, nothing written.
void write_rig(const std::string& path, const Rig& rig);

}  // namespace omnipoint::io
