#pragma once
// The text files of datasets' native layouts that calibrate their items, parsed strictly: a
// missing or malformed field is a std::runtime_error naming `source` (the file), the line and
// the problem. Fuzzed with the split lists (docs/FUZZING.md, tests/fuzz/parsers.h).
#include <array>
#include <string>

namespace omnipoint::data::formats {

// Structured3D's perspective camera_pose.txt: "vx vy vz tx ty tz ux uy uz xfov yfov 1" (eye
// position in mm, view direction, up direction, half fields of view in radians).
struct Structured3dPose {
  std::array<double, 3> eye{}, toward{}, up{};
  double half_fov_x = 0, half_fov_y = 0;  // radians, in (0, pi/2)
};
Structured3dPose parse_structured3d_pose(const std::string& text, const std::string& source);

}  // namespace omnipoint::data::formats
