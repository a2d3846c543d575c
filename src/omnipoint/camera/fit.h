#pragma once
// Camera fitting: the camera of a chosen model that best explains a per-pixel ray map (e.g.
// one predicted by the network), so users get intrinsics they can read.
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"

namespace omnipoint::camera {

// Least squares on the reprojection error of the rays (H, W, 3) at valid (H, W) pixel
// centres: Levenberg-Marquardt on the parameters (finite-difference Jacobian), started from
// a pinhole fitted in closed form to the rays nearest the axis (CameraModel::initial_params).
// Uses at most `max_samples` valid pixels, evenly spread: those on a regular pixel grid of
// about 4 max_samples pixels (finer where fewer are valid), so the cost does not grow with the
// image (every function here samples so). On a noisy 12 MP ray map the fitted parameters equal
// those of a 16x denser subsample within 1e-3 relative (absolute below 1) and the median
// residual within 0.01 degrees (tests/camera/test_fit.cpp). Throws std::invalid_argument
// when the shapes disagree with width x height, there are too few valid rays, or the fit
// ends at parameters the model rejects.
Camera fit_camera(const std::string& model, int64_t width, int64_t height, const at::Tensor& rays,
                  const at::Tensor& valid, int64_t max_samples = 4096);

// The angle between a camera's rays and given rays (H, W, 3) over the valid (H, W) pixels
// with a finite non-zero ray, on the even subsample of fit_camera of at most `max_samples` of
// them (every one up to 128x128 pixels); a pixel where the camera has no ray counts 180
// degrees.
struct AngularResidual {
  double median_deg = 0;
  double mean_deg = 0;
  double max_deg = 0;
};
AngularResidual angular_residual(const Camera& camera, const at::Tensor& rays,
                                 const at::Tensor& valid, int64_t max_samples = 16384);

struct CameraFit {
  Camera camera;
  AngularResidual residual;  // angular_residual's
};
// fit_camera of `model`, with its residual.
CameraFit fit_camera_model(const std::string& model, int64_t width, int64_t height,
                           const at::Tensor& rays, const at::Tensor& valid);

// fit_camera_model on the rays of several images of one camera together (a video's first
// frames): rays (N, H, W, 3) and valid (N, H, W); each image gives an equal share of the 4096
// samples (and of the residual's), so the camera is the one that explains all of them best.
// Levenberg-Marquardt starts from `start` (a camera of `model` at width x height, e.g. one
// image's own fit: wide rays that a pinhole start cannot project make the pinhole start end in
// a poor local minimum) when given, else from fit_camera's pinhole guess. Throws as fit_camera
// does, and std::invalid_argument for a start of another model or size.
CameraFit fit_camera_model_to_images(const std::string& model, int64_t width, int64_t height,
                                     const at::Tensor& rays, const at::Tensor& valid,
                                     const Camera* start = nullptr);

// The candidate models for rays whose widest valid ray is `max_angle_deg` from the optical
// axis (+z), simplest first: PINHOLE below 80 degrees, EQUIRECTANGULAR from 60 (cropped or
// full panoramas), UCM and OPENCV_FISHEYE below 150. The OpenCV-style pinhole distortion
// models are no candidates: their domain check makes a fit ~10x slower (0.3-0.6 s at
// 640x480), and UCM and OPENCV_FISHEYE model mild barrel distortion as well; ask for one by
// name (fit_camera_model) to get it.
std::vector<std::string> auto_fit_candidates(double max_angle_deg);

// The camera "auto" fits to rays, chosen by residual with parsimony (this is the one place
// of the rule): the candidates (auto_fit_candidates) are fitted simplest first on 1024 of the
// valid rays (20 iterations each) and scored by their mean angular residual there, stopping
// at the first scoring under 0.1 degrees; of those fitted, the first (simplest) whose mean is
// within max(0.1 degrees, 10 % of the lowest mean) of the lowest is chosen, so a distortion
// model must earn its extra parameters. That one is refined by fit_camera's fit (4096 rays)
// and its residual is angular_residual's. Throws std::invalid_argument when no candidate
// fits (with each one's error).
CameraFit fit_camera_auto(int64_t width, int64_t height, const at::Tensor& rays,
                          const at::Tensor& valid);

}  // namespace omnipoint::camera
