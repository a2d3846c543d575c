#pragma once
// Base of the equidistant (Kannala-Brandt) fisheye models: OPENCV_FISHEYE,
// SIMPLE_RADIAL_FISHEYE, RADIAL_FISHEYE, THIN_PRISM_FISHEYE, RAD_TAN_THIN_PRISM_FISHEYE.
//
// A point at angle θ = atan2(r, z) from the optical axis (r = |(x, y)|) has the equidistant
// coordinates e = θ (x, y) / r, a 2-vector of length θ. The model distorts them and scales by
// the focal length: pixel = f * distort(e) + c. Every model's distortion contains the radial
// θ-polynomial θ_d = θ (1 + k1 θ² + k2 θ⁴ + ...). Because θ is taken from atan2 and not from
// atan(r / z), the models are exact beyond 90° off-axis (fields of view over 180°), up to
// the lens's limit θ_max: the first angle in (0, π] where θ_d stops increasing (computed
// per camera by `theta_limit`). Rays beyond θ_max and pixels beyond θ_d(θ_max) are invalid.
//
// Unprojection: purely radial models solve θ_d(θ) = |m| (m the normalised pixel) by
// safeguarded 1-D Newton on [0, θ_max] (`solve_theta`, |Δθ| <= kThetaTolerance); models with
// tangential / thin-prism terms start from that radial solution and invert the full
// distortion with solve_2d (solve.h, tolerance kSolveTolerance), and both directions also
// require those terms to keep the distortion locally invertible (locally_invertible).
// Unprojection computes in float64 whatever the input dtype.
#include <vector>

#include "omnipoint/camera/camera_model.h"

namespace omnipoint::camera {

// Convergence tolerance of solve_theta, in radians (the last Newton or bisection step).
constexpr double kThetaTolerance = 1e-14;

// The radial factor 1 + k1 θ² + k2 θ⁴ + ... for θ² = `theta2` and coefficients `k` (0-d
// tensors, or empty for none).
at::Tensor radial_factor(const at::Tensor& theta2, const std::vector<at::Tensor>& k);

// The lens limit θ_max in (0, π] of θ_d = θ (1 + k1 θ² + ...): the first angle where dθ_d/dθ
// reaches 0, or π when θ_d rises all the way.
double theta_limit(const std::vector<double>& k);

// θ in [0, theta_max] with θ (1 + k1 θ² + ...) = theta_d, for theta_d (...) in
// [0, θ_d(theta_max)], by Newton's method safeguarded with bisection. float64 in and out.
at::Tensor solve_theta(const at::Tensor& theta_d, const std::vector<at::Tensor>& k,
                       double theta_max);

class EquidistantFisheyeModel : public CameraModel {
 public:
  // Positions of the radial coefficients k1, k2, ... (of θ³, θ⁵, ...) in the parameters.
  virtual std::vector<int> radial_indices() const = 0;
  // Whether `distort` has terms besides the radial polynomial (then unprojection is 2-D).
  virtual bool radial_only() const { return true; }
  // Equidistant coordinates (..., 2) -> distorted ones, element by element; `params` is 1-D
  // with the dtype/device of `equidistant`. Default: e (1 + k1 θ² + k2 θ⁴ + ...), θ = |e|.
  virtual at::Tensor distort(const at::Tensor& params, const at::Tensor& equidistant) const;

  void check_params(const std::vector<double>& params, ImageSize size) const override;
  Pixels project(const at::Tensor& params, ImageSize size, const at::Tensor& points) const override;
  Rays unproject(const at::Tensor& params, ImageSize size, const at::Tensor& pixels) const override;

  // θ_max of this model's radial polynomial for `params` (host values).
  double theta_max(const std::vector<double>& params) const;

 protected:
  // The radial coefficients as 0-d tensors of `params`, or as host values.
  std::vector<at::Tensor> radial_coefficients(const at::Tensor& params) const;
  std::vector<double> radial_coefficients(const std::vector<double>& params) const;
};

}  // namespace omnipoint::camera
