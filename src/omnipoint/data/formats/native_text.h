#pragma once
// The text files of datasets' native layouts that calibrate their items, parsed strictly: a
// missing or malformed field is a std::runtime_error naming `source` (the file), the line and
// the problem. Fuzzed with the split lists (docs/FUZZING.md, tests/fuzz/parsers.h).
#include <array>
#include <cstdint>
#include <string>

namespace omnipoint::data::formats {

// Structured3D's perspective camera_pose.txt: "vx vy vz tx ty tz ux uy uz xfov yfov 1" (eye
// position in mm, view direction, up direction, half fields of view in radians).
struct Structured3dPose {
  std::array<double, 3> eye{}, toward{}, up{};
  double half_fov_x = 0, half_fov_y = 0;  // radians, in (0, pi/2)
};
Structured3dPose parse_structured3d_pose(const std::string& text, const std::string& source);

// ARKitScenes' .pincam: one line "width height fx fy cx cy" (DATA.md), pixels; width and
// height whole numbers in [1, 100000], fx and fy > 0, cx and cy as written (their pixel
// convention is the reader's: formats/arkitscenes.cpp).
struct Pincam {
  int64_t width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};
Pincam parse_pincam(const std::string& text, const std::string& source);

}  // namespace omnipoint::data::formats
