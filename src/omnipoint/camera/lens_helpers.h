#pragma once
// Small pieces shared by the fisheye, unified and equirectangular models.
#include <vector>

#include "omnipoint/camera/camera_model.h"
#include "omnipoint/camera/solve.h"

namespace omnipoint::camera {

// The values of a 1-D parameter tensor, on the host as doubles.
std::vector<double> host_values(const at::Tensor& params);

// Pixels (..., 2) -> normalised coordinates in float64 with the intrinsics of `params64` (a
// float64 parameter tensor), zero where not finite: the start of the unprojections that
// compute in float64.
struct NormalisedPixels {
  at::Tensor normalised;  // (..., 2) float64
  at::Tensor finite;      // (...) bool
};
NormalisedPixels normalise_finite_pixels(const CameraModel& model, const at::Tensor& params64,
                                         const at::Tensor& pixels);

// Relative slack of the tests against a lens's fold (the boundary where a model stops being
// injective at a finite pixel radius): a ray or pixel on the fold itself must pass both ways
// despite rounding in `dtype`. Beyond the fold by this much, the error is of that order too.
double fold_slack(at::ScalarType dtype);

// OpenCV's tangential (decentering) terms for coordinates (..., 2):
// (2 p1 x y + p2 (r² + 2 x²), p1 (r² + 2 y²) + 2 p2 x y).
at::Tensor tangential_distortion(const at::Tensor& xy, const at::Tensor& p1, const at::Tensor& p2);

// Whether the distortion g is locally invertible and orientation-preserving at u (det J > 0,
// trace J > 0). The models check their radial polynomial's fold exactly (a circle) and use
// this for the small tangential / thin-prism terms on top, which bend that fold slightly.
at::Tensor locally_invertible(const Map2D& g, const at::Tensor& u);

}  // namespace omnipoint::camera
