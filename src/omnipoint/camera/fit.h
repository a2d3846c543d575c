#pragma once
// Camera fitting: the camera of a chosen model that best explains a per-pixel ray map (e.g.
// one predicted by the network), so users get intrinsics they can read.
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>

#include "omnipoint/camera/camera.h"

namespace omnipoint::camera {

// Least squares on the reprojection error of the rays (H, W, 3) at valid (H, W) pixel
// centres: Levenberg-Marquardt on the parameters (finite-difference Jacobian), started from
// a pinhole fitted in closed form to the rays nearest the axis (CameraModel::initial_params).
// Uses at most `max_samples` valid pixels on a regular subsample. Throws std::invalid_argument
// when the shapes disagree with width x height, there are too few valid rays, or the fit
// ends at parameters the model rejects.
Camera fit_camera(const std::string& model, int64_t width, int64_t height, const at::Tensor& rays,
                  const at::Tensor& valid, int64_t max_samples = 4096);

}  // namespace omnipoint::camera
