#pragma once
// Ground truth from a LiDAR sweep, shared by the readers of driving logs (kitti360, kitti-raw,
// rig-log): the sweep's points, in the camera frame, projected into the camera, each pixel
// labelled with the distance ‖X‖ of a point that lands on it.
//   kNearest  (the default) the pixel whose footprint holds the projection (DESIGN.md's pixels:
//             pixel (i, j) spans [i, i+1) x [j, j+1)), the nearest point winning a pixel, and
//             nothing outside the camera model's domain (behind a pinhole, beyond a fisheye's
//             field). With a calibration in the integer-centre convention read as cx = u0 + 0.5
//             (PrincipalPoint below) this rounds the calibration's coordinates to the nearest
//             pixel, as the KITTI-360 devkit's perspective projection does.
//   kDac      DAC's published KITTI-360 ground truth (viewer/kitti360PrepareDepth.py of its fork
//             of the KITTI-360 devkit, yuliangguo/kitti360Scripts): the devkit's continuous
//             coordinates (ours minus the reading's shift) truncated towards zero (numpy's
//             astype(int32); its perspective cam2image rounds them first), kept where
//             0 <= u < W, 0 <= v < H and z > 0, and the last point in file order wins a pixel:
//             no depth test, so a far point written after a near one replaces it.
#include <ATen/core/Tensor.h>

#include <string>

#include "omnipoint/camera/camera.h"

namespace omnipoint::data {

// How a calibration's principal point (u0, v0) becomes ours (pixel centres at i + 0.5):
//   kIntegerCentre  its pixel i is centred at u = i (OpenCV's convention, and the KITTI and
//                   KITTI-360 devkits': their perspective projection rounds u to the pixel
//                   index), so cx = u0 + 0.5;
//   kCorner         its pixel i spans [i, i+1) already, cx = u0 (DAC's reading of KITTI-360:
//                   its ray grid unprojects u + 0.5 through u0).
enum class PrincipalPoint { kIntegerCentre, kCorner };
// "integer-centre" | "corner"; anything else -> std::invalid_argument naming `what`.
PrincipalPoint parse_principal_point(const std::string& text, const std::string& what);
// What is added to (u0, v0): 0.5 or 0.
double principal_point_shift(PrincipalPoint reading);

enum class LidarRule { kNearest, kDac };
// "nearest" | "dac"; anything else -> std::invalid_argument naming `what`.
LidarRule parse_lidar_rule(const std::string& text, const std::string& what);

struct LidarProjection {
  LidarRule rule = LidarRule::kNearest;
  // kDac: the devkit's coordinates are ours minus this (principal_point_shift of the reading),
  // rounded rather than truncated when `round` (the devkit's perspective projection).
  double devkit_shift = 0.5;
  bool round = false;
};

struct LidarLabels {
  at::Tensor distance;  // (H, W) float32 metres, 0 where unlabelled
  at::Tensor mask;      // (H, W) bool
};

// points: (N, 3) in the camera frame (DESIGN.md's axes), any floating dtype, on the CPU.
LidarLabels lidar_labels(const at::Tensor& points, const camera::Camera& camera,
                         const LidarProjection& projection = {});

}  // namespace omnipoint::data
