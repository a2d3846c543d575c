#pragma once
// The text files of datasets' native layouts that calibrate their items, parsed strictly: a
// missing or malformed field is a std::runtime_error naming `source` (the file), the line and
// the problem. Fuzzed with the split lists (docs/FUZZING.md, tests/fuzz/parsers.h).
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <tuple>

namespace omnipoint::data::formats {

// Structured3D's perspective camera_pose.txt: "vx vy vz tx ty tz ux uy uz xfov yfov 1" (eye
// position in mm, view direction, up direction, half fields of view in radians).
struct Structured3dPose {
  std::array<double, 3> eye{}, toward{}, up{};
  double half_fov_x = 0, half_fov_y = 0;  // radians, in (0, pi/2)
};
Structured3dPose parse_structured3d_pose(const std::string& text, const std::string& source);

// Virtual KITTI 2's intrinsic.txt: a header line ("frame cameraID K[0,0] K[1,1] K[0,2] K[1,2]"),
// then "FRAME CAMERA fx fy cx cy" a line (frame and camera non-negative integers, fx, fy > 0).
// A frame and camera given twice is an error.
struct PinholeIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;  // in the file's own pixel convention
};
std::map<std::pair<int64_t, int64_t>, PinholeIntrinsics> parse_vkitti2_intrinsics(
    const std::string& text, const std::string& source);

// Hypersim's metadata_camera_parameters.csv (ml-hypersim contrib/mikeroberts3000): one row per
// scene; read are scene_name, settings_output_img_{width,height} and M_cam_from_uv_00..22.
struct HypersimCamera {
  int64_t width = 0, height = 0;
  // Row-major 3x3: (u, v, 1) in NDC (u right, v up, in (-1, 1)) -> a ray in Hypersim's camera
  // frame (x right, y up, z backwards).
  std::array<double, 9> cam_from_uv{};
};
std::map<std::string, HypersimCamera> parse_hypersim_cameras(const std::string& text,
                                                             const std::string& source);
// Hypersim's metadata_images_split_scene_v1.csv: (scene_name, camera_name, frame_id) -> its
// split_partition_name (train, val or test), for the rows with included_in_public_release True.
using HypersimFrame = std::tuple<std::string, std::string, int64_t>;
std::map<HypersimFrame, std::string> parse_hypersim_split(const std::string& text,
                                                          const std::string& source);

// ARKitScenes' .pincam: one line "width height fx fy cx cy" (DATA.md), pixels; width and
// height whole numbers in [1, 100000], fx and fy > 0, cx and cy as written (their pixel
// convention is the reader's: formats/arkitscenes.cpp).
struct Pincam {
  int64_t width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};
Pincam parse_pincam(const std::string& text, const std::string& source);

}  // namespace omnipoint::data::formats
