#pragma once
// The text files of KITTI raw and KITTI-360 (calibrations, poses, split lists), parsed without
// the file system: the readers (kitti360.cpp, kitti_raw.cpp) call these on a file's text, and
// so do the fuzz targets and the parser replay. Each reader's conventions and their sources are
// written beside it. Errors: std::invalid_argument, one line naming `name` and the problem (a
// missing key names the key).
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/formats/lidar_labels.h"

namespace omnipoint::data {

// "image_00" .. "image_03"; anything else -> std::invalid_argument naming `what`.
void check_kitti_camera_name(const std::string& camera, const std::string& what);

// KITTI-360 calibration/image_0X.yaml (OpenCV FileStorage YAML of the MEI model: model_type,
// image_width, image_height, mirror_parameters{xi}, distortion_parameters{k1, k2, p1, p2},
// projection_parameters{gamma1, gamma2, u0, v0}) as our MEI camera
// (fx fy cx cy xi k1 k2 p1 p2), (u0, v0) read by `reading`; p1 and p2 kept when `tangential`,
// else 0 (the devkit's projection ignores them).
camera::Camera parse_kitti360_fisheye(const std::string& text, const std::string& name,
                                      PrincipalPoint reading, bool tangential);

// KITTI-360 calibration/perspective.txt for one rectified camera (image_00 or image_01): the
// PINHOLE camera of P_rect_0X (its K; the devkit ignores the fourth column) and S_rect_0X,
// and R_rect_0X as a (4, 4) float64 rectified-from-unrectified rotation.
struct Kitti360Perspective {
  camera::Camera camera;
  at::Tensor rect_from_camera;
};
Kitti360Perspective parse_kitti360_perspective(const std::string& text, const std::string& name,
                                               const std::string& camera_name,
                                               PrincipalPoint reading);

// KITTI-360 calibration/calib_cam_to_pose.txt: "image_0X: 12 numbers" (3x4 row-major,
// camera -> GPS/IMU pose frame), as (4, 4) float64 by camera name.
std::map<std::string, at::Tensor> parse_kitti360_cam_to_pose(const std::string& text,
                                                             const std::string& name);

// KITTI-360 calibration/calib_cam_to_velo.txt: 12 numbers (3x4 row-major, the unrectified
// image_00 camera -> Velodyne), as (4, 4) float64.
at::Tensor parse_kitti360_cam_to_velo(const std::string& text, const std::string& name);

// KITTI-360 data_poses/<sequence>/poses.txt: lines "FRAME r11 ... t3" (a frame index and a 3x4
// row-major pose -> world transform), as (4, 4) float64 by frame. Not every frame has one.
std::map<int64_t, at::Tensor> parse_kitti360_poses(const std::string& text,
                                                   const std::string& name);

// KITTI raw <date>/calib_cam_to_cam.txt for one camera (image_00 .. image_03): the PINHOLE
// camera of its rectified projection P_rect_0X (K | K t) and size S_rect_0X, and the (4, 4)
// float64 transform from reference camera 0's unrectified frame into it, [I | t] · R_rect_00
// (KITTI raw devkit, readme.txt: "P_rect_xx · R_rect_00 · (R|T)_velo_to_cam · X").
struct KittiRawCamera {
  camera::Camera camera;
  at::Tensor camera_from_cam0;
};
KittiRawCamera parse_kitti_raw_camera(const std::string& text, const std::string& name,
                                      const std::string& camera_name, PrincipalPoint reading);

// A KITTI-360 split list in DAC's form, one frame a line: "IMAGE [DEPTH [FOCAL]]", paths
// relative to the dataset root (DEPTH: a uint16/256 distance PNG of DAC's proj_depth layout;
// FOCAL is γ1, informative only). Blank lines are skipped.
struct Kitti360ListEntry {
  int64_t line = 0;
  std::string image, depth;
};
std::vector<Kitti360ListEntry> parse_kitti360_list(const std::string& text,
                                                   const std::string& name);

// A KITTI raw split list in the form monodepth2 and its successors ship (the Eigen split's
// files): "DATE/DRIVE FRAME [l|r]", e.g. "2011_09_26/2011_09_26_drive_0002_sync 69 l"; l is
// image_02, r image_03, none: the reader's camera option.
struct KittiRawListEntry {
  int64_t line = 0;
  std::string drive;  // "2011_09_26/2011_09_26_drive_0002_sync"
  int64_t frame = 0;
  std::string camera;  // "image_02", "image_03" or "" (the option's)
};
std::vector<KittiRawListEntry> parse_kitti_raw_list(const std::string& text,
                                                    const std::string& name);

}  // namespace omnipoint::data
