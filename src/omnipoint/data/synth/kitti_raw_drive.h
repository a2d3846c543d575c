#pragma once
// A synthetic driving log in the KITTI raw layout: frames of the scene engine with the sweeps
// of a rotating LiDAR cast into the same scenes, written as KITTI's files, so that the
// "kitti-raw" reader (data/formats/kitti_raw.cpp) turns them into sparse metric labels exactly
// as it does a car's logs (`omnipoint synth --kitti-raw`; docs/TRAINING.md's sparse-label
// fine-tune). The root holds
//   DATE/calib_cam_to_cam.txt, DATE/calib_velo_to_cam.txt        (DATE = kSynthDriveDate)
//   DATE/DATE_drive_0001_sync/{image_02,velodyne_points}/data/   the training frames
//   DATE/DATE_drive_0002_sync/...                                the held-out frames
//   train_files.txt, test_files.txt                              their split lists
//                                                                ("DATE/DRIVE FRAME l")
// Geometry: the camera is image_02 (rectified, R_rect_00 = I, P_rect_0X = K [I | t_X] with
// KITTI's baselines); the Velodyne frame is KITTI's (x forward, y left, z up) and sits at
// image_02's optical centre, so every return lies on a surface the camera sees along the same
// ray: the labels are the renderer's exact distances (a real rig's offset adds parallax, points
// the LiDAR sees behind what the camera sees). The principal point is written in the devkit's
// integer-centre convention (u0 = cx - 0.5). Beam b fires at elevation min + b·(max - min) /
// (beams - 1) and azimuth 2π·k / azimuth_steps for every k (a full revolution; the reader keeps
// what lies in front of the camera); a beam without a surface within `lidar_range` returns
// nothing. Sweeps are float32 x, y, z, reflectance (0.5 for every return).
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/scene.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/geometry/sparse_sampling.h"

namespace omnipoint::data::synth {

inline constexpr const char* kSynthDriveDate = "2000_01_01";

struct KittiRawDriveOptions {
  // image_02's: a PINHOLE camera (rectified images); by default KITTI's field of view at 192x64.
  camera::Camera camera{"PINHOLE", 192, 64, {112, 112, 96, 32}};
  SceneKind scene = SceneKind::kOutdoor;  // the scenes of every frame
  std::uint64_t seed = 0;                 // training frame i renders seed + i, held-out ones next
  int64_t frames = 1;                     // training frames (drive 0001)
  int64_t held_out = 0;                   // held-out frames (drive 0002)
  geometry::LidarPattern lidar;           // the sensor (default: a 64-beam HDL-64E-like one)
  double lidar_range = 120.0;             // metres: farther surfaces return nothing
  SynthOptions synth;                     // the images' render settings

  // std::invalid_argument, one line naming the option, when no drive can be written.
  void Check() const;
};

struct KittiRawDriveSummary {
  std::vector<std::string> train_frames, test_frames;  // the split lists' lines
  int64_t returns = 0;                                 // LiDAR points written, all sweeps
  double label_density = 0.0;  // the mean share of image pixels that get a label
};

// The camera frame (x right, y down, z forward) from KITTI's Velodyne frame (x forward, y left,
// z up): (3, 3) float64.
at::Tensor camera_from_velodyne_axes();

// The beams' unit directions (beams, azimuth_steps, 3) float64 in the LiDAR's own frame (the
// Velodyne's: x forward, y left, z up), by the pattern of the top.
at::Tensor lidar_beam_directions(const geometry::LidarPattern& pattern);

// std::invalid_argument, one line, for a pattern or range no LiDAR has.
void check_lidar(const geometry::LidarPattern& pattern, double range);

// Writes the root `root` (a folder that must not exist or be empty): whole or not at all (it is
// written into a staging folder and renamed into place). std::invalid_argument for bad options
// or a non-empty root; std::runtime_error when a file cannot be written.
KittiRawDriveSummary write_kitti_raw_drive(const std::string& root,
                                           const KittiRawDriveOptions& options);

}  // namespace omnipoint::data::synth
