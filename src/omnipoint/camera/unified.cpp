// UCM (fx fy cx cy alpha), EUCM (fx fy cx cy alpha beta; Khomutenko et al. 2016, COLMAP's
// order) and DOUBLE_SPHERE (fx fy cx cy xi alpha), with the shared helpers of unified.h.
// All three have closed-form unprojections (Usenko et al. 2018).
#include "omnipoint/camera/unified.h"

#include <ATen/ATen.h>

#include <limits>

namespace omnipoint::camera {

double unified_domain_weight(double alpha) {
  return alpha <= 0.5 ? alpha / (1.0 - alpha) : (1.0 - alpha) / alpha;
}

PlaneDepth eucm_plane_depth(const at::Tensor& r2, double alpha, const at::Tensor& beta,
                            double slack) {
  const auto s = 1.0 - (2.0 * alpha - 1.0) * beta * r2;
  const auto root = at::sqrt(s.clamp_min(0.0));
  // Usenko's m_z = (1 − β α² r²) / (α sqrt(s) + 1 − α) has a vanishing denominator at the
  // fold for α -> 1; multiplying out gives the equal (α sqrt(s) − (1 − α)) / (2α − 1),
  // which is well conditioned there. Each form is used where its denominator is >= 1/4.
  const auto mz = alpha <= 0.75
                      ? (1.0 - beta * (alpha * alpha) * r2) / (alpha * root + (1.0 - alpha))
                      : (alpha * root - (1.0 - alpha)) / (2.0 * alpha - 1.0);
  return {mz, s >= -slack};
}

Rays lift_to_shifted_sphere(const at::Tensor& m, const at::Tensor& xi, double slack) {
  // |λ m − (0, 0, ξ)| = 1 for λ > 0: λ = (ξ m_z + sqrt(m_z² + (1 − ξ²) r²)) / |m|².
  const auto mz = m.select(-1, 2);
  const auto r2 = squared_length(m.narrow(-1, 0, 2));
  const auto discriminant = mz * mz + (1.0 - xi * xi) * r2;
  const auto norm2 = r2 + mz * mz;
  const auto valid = (discriminant >= -slack * norm2) & (norm2 > 0);
  const auto lambda = (xi * mz + at::sqrt(discriminant.clamp_min(0.0))) /
                      at::where(valid, norm2, at::ones_like(norm2));
  const auto shift = at::stack({at::zeros_like(xi), at::zeros_like(xi), xi});
  auto rays = lambda.unsqueeze(-1) * m - shift;
  rays = rays / length(rays).unsqueeze(-1).clamp_min(std::numeric_limits<double>::min());
  return {at::where(valid.unsqueeze(-1), rays, at::zeros_like(rays)), valid};
}

namespace {

// Pixels from normalised coordinates (x, y) / den where `valid`, zero elsewhere.
Pixels pixels_from_plane(const CameraModel& model, const at::Tensor& params, const at::Tensor& xy,
                         const at::Tensor& den, const at::Tensor& valid) {
  const auto safe_den = at::where(valid, den, at::ones_like(den)).unsqueeze(-1);
  const auto pixels = denormalise_pixels(focal_principal(model, params), xy / safe_den);
  return {at::where(valid.unsqueeze(-1), pixels, at::zeros_like(pixels)), valid};
}

// UCM and EUCM: UCM is EUCM with β = 1 (it has no beta parameter).
class EnhancedUnifiedModel final : public CameraModel {
 public:
  explicit EnhancedUnifiedModel(bool has_beta) : has_beta_(has_beta) {}

  std::string name() const override { return has_beta_ ? "EUCM" : "UCM"; }
  std::vector<std::string> param_names() const override {
    if (has_beta_) return {"fx", "fy", "cx", "cy", "alpha", "beta"};
    return {"fx", "fy", "cx", "cy", "alpha"};
  }

  void check_params(const std::vector<double>& params, ImageSize) const override {
    check_focal_positive(*this, params);
    const double alpha = params[4];
    require_param(*this, "alpha", alpha, alpha >= 0 && alpha <= 1, "in [0, 1]");
    if (has_beta_) {
      const double beta = params[5];
      require_param(*this, "beta", beta, beta > 0, "> 0");
    }
  }

  std::vector<double> initial_params(double fx, double fy, double cx, double cy,
                                     ImageSize size) const override {
    // α = 0.5 (β = 1) projects every direction but the backward axis, so fitting sees all
    // rays of a wide lens from the start; near the axis it matches the pinhole guess.
    auto params = CameraModel::initial_params(fx, fy, cx, cy, size);
    params[4] = 0.5;                 // alpha
    if (has_beta_) params[5] = 1.0;  // beta
    return params;
  }

  Pixels project(const at::Tensor& params, ImageSize, const at::Tensor& points) const override {
    const double alpha_value = host_values(params)[4];
    const auto alpha = params[4];
    const auto xy = points.narrow(-1, 0, 2);
    const auto z = points.select(-1, 2);
    const auto d = at::sqrt(beta(params) * squared_length(xy) + z * z);
    const auto den = alpha * d + (1.0 - alpha) * z;
    const auto norm = length(points);
    const auto valid =
        all_finite(points) & (norm > 0) & (den > 0) &
        (z + unified_domain_weight(alpha_value) * d >= -fold_slack(points.scalar_type()) * norm);
    return pixels_from_plane(*this, params, xy, den, valid);
  }

  Rays unproject(const at::Tensor& params, ImageSize, const at::Tensor& pixels) const override {
    const double alpha = host_values(params)[4];
    const auto params64 = params.detach().to(at::kDouble);
    const auto [m, finite] = normalise_finite_pixels(*this, params64, pixels);
    const auto depth = eucm_plane_depth(squared_length(m), alpha, beta(params64),
                                        fold_slack(pixels.scalar_type()));
    auto rays = at::cat({m, depth.mz.unsqueeze(-1)}, -1);
    rays = rays / length(rays).unsqueeze(-1);
    const auto valid = finite & depth.valid & all_finite(rays);
    return {at::where(valid.unsqueeze(-1), rays, at::zeros_like(rays)).to(pixels.scalar_type()),
            valid};
  }

 private:
  // β: EUCM's parameter, 1 for UCM.
  at::Tensor beta(const at::Tensor& params) const {
    return has_beta_ ? params[5] : at::ones({}, params.options());
  }

  bool has_beta_;
};

// DOUBLE_SPHERE: the point moves to the unit sphere, shifts by ξ along z, and is projected
// by UCM with α. That is injective exactly where the shifted point q = (x, y, ξ d1 + z) lies
// in UCM's domain, ξ d1 + z > −w1 d2 with d2 = |q|. (Usenko et al. state it as z > −w2 d1,
// w2 = (w1 + ξ) / sqrt(2 w1 ξ + ξ² + 1), which agrees for ξ in [0, 1] but not for every
// negative ξ, so the shifted form is used.) ξ is restricted to (−1, 1), where the shifted
// sphere contains the origin and its unprojection is unique.
class DoubleSphereModel final : public CameraModel {
 public:
  std::string name() const override { return "DOUBLE_SPHERE"; }
  std::vector<std::string> param_names() const override {
    return {"fx", "fy", "cx", "cy", "xi", "alpha"};
  }

  void check_params(const std::vector<double>& params, ImageSize) const override {
    check_focal_positive(*this, params);
    const double xi = params[4];
    const double alpha = params[5];
    require_param(*this, "xi", xi, xi > -1 && xi < 1, "in (-1, 1)");
    require_param(*this, "alpha", alpha, alpha >= 0 && alpha <= 1, "in [0, 1]");
  }

  std::vector<double> initial_params(double fx, double fy, double cx, double cy,
                                     ImageSize size) const override {
    // ξ = 0, α = 0.5: UCM's start (see EnhancedUnifiedModel::initial_params).
    auto params = CameraModel::initial_params(fx, fy, cx, cy, size);
    params[5] = 0.5;  // alpha
    return params;
  }

  Pixels project(const at::Tensor& params, ImageSize, const at::Tensor& points) const override {
    const double alpha_value = host_values(params)[5];
    const auto xi = params[4];
    const auto alpha = params[5];
    const auto xy = points.narrow(-1, 0, 2);
    const auto d1 = length(points);
    const auto shifted_z = xi * d1 + points.select(-1, 2);
    const auto d2 = at::sqrt(squared_length(xy) + shifted_z * shifted_z);
    const auto den = alpha * d2 + (1.0 - alpha) * shifted_z;
    const auto valid = all_finite(points) & (d1 > 0) & (den > 0) &
                       (shifted_z + unified_domain_weight(alpha_value) * d2 >=
                        -fold_slack(points.scalar_type()) * d1);
    return pixels_from_plane(*this, params, xy, den, valid);
  }

  Rays unproject(const at::Tensor& params, ImageSize, const at::Tensor& pixels) const override {
    const double alpha = host_values(params)[5];
    const auto params64 = params.detach().to(at::kDouble);
    const auto xi = params64[4];
    const auto [m, finite] = normalise_finite_pixels(*this, params64, pixels);
    const double slack = fold_slack(pixels.scalar_type());
    const auto depth = eucm_plane_depth(squared_length(m), alpha, at::ones({}, m.options()), slack);
    const auto lifted = lift_to_shifted_sphere(at::cat({m, depth.mz.unsqueeze(-1)}, -1), xi, slack);
    const auto valid = finite & depth.valid & lifted.valid & all_finite(lifted.rays);
    return {at::where(valid.unsqueeze(-1), lifted.rays, at::zeros_like(lifted.rays))
                .to(pixels.scalar_type()),
            valid};
  }
};

}  // namespace

const CameraModel& ucm_model() {
  static const EnhancedUnifiedModel model(/*has_beta=*/false);
  return model;
}

const CameraModel& eucm_model() {
  static const EnhancedUnifiedModel model(/*has_beta=*/true);
  return model;
}

const CameraModel& double_sphere_model() {
  static const DoubleSphereModel model;
  return model;
}

}  // namespace omnipoint::camera
