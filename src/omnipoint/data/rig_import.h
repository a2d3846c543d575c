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
//   nuScenes (a v1.0-* metadata folder: scene.json, sample_data.json, calibrated_sensor.json,
//     sensor.json): body = the ego vehicle frame. A scene's first sample's key-frame sample_data
//     records give one calibrated_sensor per channel: translation and (w, x, y, z) rotation
//     quaternion take the sensor's points into the ego frame (as the devkit applies them);
//     cameras are PINHOLE from camera_intrinsic at the record's width x height; LIDAR_TOP is
//     the LiDAR.
// The LiDAR format is "kitti" (float32 x, y, z, reflectance sweeps) for the KITTIs, "nuscenes"
// (x, y, z, intensity, ring: the .pcd.bin sweeps) for nuScenes.
#include <string>
#include <vector>

#include "omnipoint/io/rig.h"

namespace omnipoint::data {

struct RigImportOptions {
  std::string kitti360_root;   // a KITTI-360 root (its calibration/ folder is read)
  std::string kitti_raw_date;  // a KITTI raw date folder (calib_cam_to_cam.txt, ...)
  // A nuScenes metadata folder (v1.0-mini, ...; or the dataroot holding exactly one).
  std::string nuscenes_json;
  // The nuScenes scene (scene.json "name") whose calibration is read; empty: the first.
  std::string nuscenes_scene;
  // The cameras to import, by the dataset's names (image_00 .. image_03; nuScenes channels,
  // CAM_FRONT, ...), in this order; empty: all (nuScenes: sensor.json's order).
  std::vector<std::string> cameras;
  // (u0, v0) of the calibrations: "integer-centre" (the devkits': cx = u0 + 0.5) or "corner"
  // (cx = u0), as the readers' option principal_point.
  std::string principal_point = "integer-centre";
  // Throws std::invalid_argument naming the first bad field (exactly one source is given).
  void Check() const;
};

// The rig of the calibration. A missing or malformed calibration file or key ->
// std::runtime_error or std::invalid_argument, one line naming the file and the problem.
// `notes`, when given, receives lines for the user (the nuScenes scene chosen by default).
io::Rig import_rig(const RigImportOptions& options, std::vector<std::string>* notes = nullptr);

}  // namespace omnipoint::data
