#pragma once
// `omnipoint rig import`: a rig file (io/rig.h, docs/RIG.md) from a dataset's calibration, read
// by the dataset readers' own parsers (formats/kitti_text.h), so a rig's cameras are exactly the
// cameras the readers give the images:
//   KITTI-360 (ROOT/calibration/): body = the GPS/IMU pose frame of calib_cam_to_pose.txt.
//     A fisheye (image_02, image_03; image_0X.yaml) is posed by its camera -> pose transform;
//     a perspective camera (image_00, image_01; perspective.txt) is the rectified one, posed
//     by cam_to_pose · R_rect_0Xᵀ; the Velodyne by cam_to_pose[image_00] · cam_to_velo⁻¹.
//   KITTI raw (a DATE folder: calib_cam_to_cam.txt, calib_velo_to_cam.txt): body = the Velodyne
//     frame (KITTI raw's calibration chain starts there); camera X is the rectified camera of
//     P_rect_0X, posed by ([I | t_X] · R_rect_00 · (R|T))⁻¹; the LiDAR is the identity.
// The LiDAR format is "kitti" (float32 x, y, z, reflectance sweeps) for both.
#include <string>
#include <vector>

#include "omnipoint/io/rig.h"

namespace omnipoint::data {

struct RigImportOptions {
  std::string kitti360_root;   // a KITTI-360 root (its calibration/ folder is read)
  std::string kitti_raw_date;  // a KITTI raw date folder (calib_cam_to_cam.txt, ...)
  // The cameras to import, by the dataset's names (image_00 .. image_03); empty: all four.
  std::vector<std::string> cameras;
  // (u0, v0) of the calibrations: "integer-centre" (the devkits': cx = u0 + 0.5) or "corner"
  // (cx = u0), as the readers' option principal_point.
  std::string principal_point = "integer-centre";
  // Throws std::invalid_argument naming the first bad field (exactly one source is given).
  void Check() const;
};

// The rig of the calibration. A missing or malformed calibration file or key ->
// std::runtime_error or std::invalid_argument, one line naming the file and the problem.
io::Rig import_rig(const RigImportOptions& options);

}  // namespace omnipoint::data
