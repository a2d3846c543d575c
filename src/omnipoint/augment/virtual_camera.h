#pragma once
// Random virtual cameras for P2A: which lens models, fields of view, image sizes and
// orientations the augmentation draws, and which batch items it applies to (the paper
// converts 2 % of each stage-2 batch).
//
// Fisheyes are centred, square-pixel, with the image circle inscribed in the shorter side
// (the FoV is the full angle across it); their focal length is solved from the model's own
// projection of the rim ray, so every model and parameter draw hits the FoV exactly.
// Orientations (warp.h angles) keep the virtual axis near the source axis for fisheyes
// (their centre should see the source content) and take any yaw for full panoramas.
// Randomness: a CPU at::Generator, so a seed gives the same cameras on every device.
#include <ATen/core/Generator.h>

#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/augment/p2a.h"

namespace omnipoint::augment {

struct VirtualCameraDistribution {
  // Relative weights of the target kinds: OPENCV_FISHEYE, MEI, EUCM, DOUBLE_SPHERE, a full
  // EQUIRECTANGULAR panorama, a cropped EQUIRECTANGULAR panorama.
  std::vector<double> weights{1, 1, 1, 1, 1, 1};
  double min_fisheye_fov_deg = 120, max_fisheye_fov_deg = 220;
  int64_t fisheye_size = 512;                            // fisheye images are square
  int64_t panorama_width = 1024;                         // full panoramas are W × W/2
  double min_crop_lon_deg = 90, max_crop_lon_deg = 270;  // cropped panorama extent
  double min_crop_lat_deg = 60, max_crop_lat_deg = 150;
  double max_yaw_deg = 30, max_pitch_deg = 20, max_roll_deg = 10;  // fisheyes, cropped panoramas
};

// One random virtual camera and its rotation (centre 0).
VirtualView sample_virtual_view(const VirtualCameraDistribution& distribution,
                                at::Generator generator);

// A centred fisheye of `model` (OPENCV_FISHEYE, MEI, EUCM, DOUBLE_SPHERE; `shape` holds the
// model's dimensionless parameters in COLMAP order, after fx fy cx cy) whose image circle,
// inscribed in width × height, spans `fov_deg`. std::invalid_argument when the model cannot
// see that far with these parameters.
camera::Camera fisheye_with_fov(const std::string& model, int64_t width, int64_t height,
                                double fov_deg, const std::vector<double>& shape);

// Which of `batch_size` items to convert, each with `probability`.
std::vector<bool> select_items(int64_t batch_size, double probability, at::Generator generator);

}  // namespace omnipoint::augment
