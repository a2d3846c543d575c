#include "omnipoint/camera/fit.h"

#include <ATen/ATen.h>

#include <cmath>
#include <stdexcept>

namespace omnipoint::camera {
namespace {

struct Samples {
  at::Tensor rays;    // (N, 3) unit, float64
  at::Tensor pixels;  // (N, 2) pixel centres, float64
};

Samples sample_valid_pixels(const at::Tensor& rays, const at::Tensor& valid, int64_t width,
                            int64_t max_samples) {
  const auto flat = rays.to(at::kCPU, at::kDouble).reshape({-1, 3});
  const auto usable =
      valid.to(at::kCPU).to(at::kBool).reshape({-1}) & all_finite(flat) & (length(flat) > 0);
  auto index = usable.nonzero().squeeze(1);
  const int64_t stride = std::max<int64_t>(1, (index.numel() + max_samples - 1) / max_samples);
  index = index.slice(0, 0, index.numel(), stride);
  const auto selected = flat.index_select(0, index);
  const auto pixels = at::stack({at::remainder(index, width).to(at::kDouble) + 0.5,
                                 at::floor_divide(index, width).to(at::kDouble) + 0.5},
                                -1);
  return {selected / length(selected).unsqueeze(-1), pixels};
}

// Least-squares line value = slope * a + offset.
std::pair<double, double> fit_line(const at::Tensor& a, const at::Tensor& value) {
  const auto a_centred = a - a.mean();
  const double variance = (a_centred * a_centred).sum().item<double>();
  const double slope =
      variance > 0 ? (a_centred * (value - value.mean())).sum().item<double>() / variance : 0;
  return {slope, (value - slope * a).mean().item<double>()};
}

// A pinhole (fx, fy, cx, cy) from the quarter of the rays in front of the camera nearest to
// the axis, where every lens is close to a pinhole.
std::vector<double> pinhole_guess(const Samples& samples, ImageSize size) {
  const auto z = samples.rays.select(-1, 2);
  const auto front = (z > 1e-6).nonzero().squeeze(1);
  const double fallback_focal = 0.5 * size.width;  // a 90 degree lens
  if (front.numel() < 8)
    return {fallback_focal, fallback_focal, 0.5 * size.width, 0.5 * size.height};
  const auto zf = z.index_select(0, front);
  const int64_t quarter = std::max<int64_t>(8, front.numel() / 4);
  const auto nearest = std::get<1>(at::topk(zf, quarter));  // largest z: smallest angles
  const auto chosen = front.index_select(0, nearest);
  const auto rays = samples.rays.index_select(0, chosen);
  const auto pixels = samples.pixels.index_select(0, chosen);
  const auto a = rays.select(-1, 0) / rays.select(-1, 2);
  const auto b = rays.select(-1, 1) / rays.select(-1, 2);
  auto [fx, cx] = fit_line(a, pixels.select(-1, 0));
  auto [fy, cy] = fit_line(b, pixels.select(-1, 1));
  if (!(fx > 0) || !(fy > 0))
    return {fallback_focal, fallback_focal, 0.5 * size.width, 0.5 * size.height};
  return {fx, fy, cx, cy};
}

bool acceptable(const CameraModel& model, const std::vector<double>& params, ImageSize size) {
  for (const double value : params) {
    if (!std::isfinite(value)) return false;
  }
  try {
    model.check_params(params, size);
  } catch (const std::invalid_argument&) {
    return false;
  }
  return true;
}

}  // namespace

Camera fit_camera(const std::string& model_name, int64_t width, int64_t height,
                  const at::Tensor& rays, const at::Tensor& valid, int64_t max_samples) {
  const auto& model = find_camera_model(model_name);
  if (rays.dim() != 3 || rays.size(0) != height || rays.size(1) != width || rays.size(2) != 3 ||
      valid.sizes() != rays.sizes().slice(0, 2)) {
    throw std::invalid_argument("fit_camera: expects rays (" + std::to_string(height) + ", " +
                                std::to_string(width) + ", 3) and valid (" +
                                std::to_string(height) + ", " + std::to_string(width) + ")");
  }
  const ImageSize size{width, height};
  const auto samples = sample_valid_pixels(rays, valid, width, max_samples);
  if (samples.rays.size(0) < 16) {
    throw std::invalid_argument("fit_camera: needs at least 16 valid rays, got " +
                                std::to_string(samples.rays.size(0)));
  }
  const auto guess = pinhole_guess(samples, size);
  std::vector<double> params = model.initial_params(guess[0], guess[1], guess[2], guess[3], size);

  // Reprojection residuals (2N); rays the parameters cannot project cost an image diagonal.
  const double penalty = std::hypot(static_cast<double>(width), static_cast<double>(height));
  const auto residual = [&](const std::vector<double>& p) {
    const auto projected = model.project(at::tensor(p, at::kDouble), size, samples.rays);
    const auto difference = projected.pixels - samples.pixels;
    return at::where(projected.valid.unsqueeze(-1), difference, at::full_like(difference, penalty))
        .reshape({-1});
  };

  const int64_t count = static_cast<int64_t>(params.size());
  auto r = residual(params);
  double cost = (r * r).sum().item<double>();
  double lambda = 1e-3;
  for (int iteration = 0; iteration < 100 && count > 0; ++iteration) {
    auto jacobian = at::empty({r.size(0), count}, r.options());
    for (int64_t i = 0; i < count; ++i) {
      auto shifted = params;
      const double h = 1e-7 * std::max(1.0, std::abs(params[i]));
      shifted[i] += h;
      jacobian.select(1, i).copy_((residual(shifted) - r) / h);
    }
    const auto jt = jacobian.t();
    const auto normal = at::matmul(jt, jacobian);
    const auto gradient = at::matmul(jt, r);
    bool improved = false;
    while (lambda < 1e12) {
      const auto damped = normal + at::diag(normal.diagonal() * lambda + 1e-12);
      const auto step = at::linalg_solve(damped, -gradient);
      std::vector<double> candidate = params;
      for (int64_t i = 0; i < count; ++i) candidate[i] += step[i].item<double>();
      if (acceptable(model, candidate, size)) {
        const auto candidate_r = residual(candidate);
        const double candidate_cost = (candidate_r * candidate_r).sum().item<double>();
        if (candidate_cost < cost) {
          improved = cost - candidate_cost > 1e-14 * cost;
          params = candidate;
          r = candidate_r;
          cost = candidate_cost;
          lambda = std::max(lambda * 0.1, 1e-12);
          break;
        }
      }
      lambda *= 10;
    }
    if (!improved) break;
  }
  try {
    return Camera(model_name, width, height, params);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("fit_camera: fitting " + model_name +
                                " to the ray map failed: " + e.what());
  }
}

}  // namespace omnipoint::camera
