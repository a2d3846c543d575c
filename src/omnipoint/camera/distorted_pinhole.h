#pragma once
// Base of the models "pinhole + distortion of normalised coordinates" (SIMPLE_RADIAL, RADIAL,
// OPENCV, FULL_OPENCV): pixel = f * distort(x / z, y / z) + c. A model only provides
// `distort`; projection marks z <= 0 and points beyond the distortion's monotonic range
// invalid, unprojection inverts `distort` with solve_2d (tolerance kSolveTolerance) inside
// that range; pixels without a preimage there are invalid.
#include "omnipoint/camera/camera_model.h"

namespace omnipoint::camera {

class DistortedPinholeModel : public CameraModel {
 public:
  // Undistorted normalised coordinates (..., 2) -> distorted ones, with `params` (1-D, the
  // dtype/device of `undistorted`). Must act element by element (see Map2D in solve.h).
  virtual at::Tensor distort(const at::Tensor& params, const at::Tensor& undistorted) const = 0;

  // Radius (normalised coordinates) of the disc around the axis where `distort` is monotonic
  // (solve.h: monotonic_radius); points beyond it are invalid.
  double monotonic_radius(const at::Tensor& params) const;

  void check_params(const std::vector<double>& params, ImageSize size) const override;
  Pixels project(const at::Tensor& params, ImageSize size, const at::Tensor& points) const override;
  Rays unproject(const at::Tensor& params, ImageSize size, const at::Tensor& pixels) const override;
};

// Points (..., 3) -> (x / z, y / z) and valid = z > 0; where invalid the result is 0.
struct PlaneProjection {
  at::Tensor normalised;
  at::Tensor valid;
};
PlaneProjection project_to_plane(const at::Tensor& points);

}  // namespace omnipoint::camera
