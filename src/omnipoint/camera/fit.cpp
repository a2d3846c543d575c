#include "omnipoint/camera/fit.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace omnipoint::camera {
namespace {

struct Samples {
  at::Tensor rays;    // (N, 3) unit, float64
  at::Tensor pixels;  // (N, 2) pixel centres, float64
};

// At most max_samples of the valid pixels with a finite non-zero ray, evenly spread: found on a
// regular pixel grid of about 4 max_samples pixels (halving its spacing while it holds fewer
// usable pixels than max_samples, down to every pixel), then every k-th of those. The cost
// follows max_samples, not the image size.
Samples sample_valid_pixels(const at::Tensor& rays, const at::Tensor& valid, int64_t width,
                            int64_t max_samples) {
  const int64_t height = rays.size(0);
  const at::Tensor all_rays = rays.to(at::kCPU), all_valid = valid.to(at::kCPU);
  const double pixels_per_cell = static_cast<double>(width * height) / (4.0 * max_samples);
  int64_t spacing = std::max<int64_t>(1, static_cast<int64_t>(std::sqrt(pixels_per_cell)));
  while (true) {
    const int64_t offset = (spacing - 1) / 2;  // the grid centred in its cells
    const auto on_grid = [&](const at::Tensor& map) {
      return map.slice(0, offset, height, spacing).slice(1, offset, width, spacing);
    };
    // Selected first, converted after: the full map stays in its dtype.
    const at::Tensor grid_rays = on_grid(all_rays);
    const int64_t grid_width = grid_rays.size(1);
    const at::Tensor flat = grid_rays.reshape({-1, 3});
    const at::Tensor usable =
        on_grid(all_valid).to(at::kBool).reshape({-1}) & all_finite(flat) & (length(flat) > 0);
    at::Tensor index = usable.nonzero().squeeze(1);
    if (index.numel() < max_samples && spacing > 1) {
      spacing /= 2;
      continue;
    }
    const int64_t stride = std::max<int64_t>(1, (index.numel() + max_samples - 1) / max_samples);
    index = index.slice(0, 0, index.numel(), stride);
    const auto selected = flat.index_select(0, index).to(at::kDouble);
    const auto centre = [&](const at::Tensor& grid_coordinate) {
      return (grid_coordinate * spacing + offset).to(at::kDouble) + 0.5;
    };
    const auto pixels = at::stack(
        {centre(at::remainder(index, grid_width)), centre(at::floor_divide(index, grid_width))},
        -1);
    return {selected / length(selected).unsqueeze(-1), pixels};
  }
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

void check_shapes(const char* what, int64_t width, int64_t height, const at::Tensor& rays,
                  const at::Tensor& valid) {
  if (rays.dim() != 3 || rays.size(0) != height || rays.size(1) != width || rays.size(2) != 3 ||
      valid.sizes() != rays.sizes().slice(0, 2)) {
    throw std::invalid_argument(std::string(what) + ": expects rays (" + std::to_string(height) +
                                ", " + std::to_string(width) + ", 3) and valid (" +
                                std::to_string(height) + ", " + std::to_string(width) + ")");
  }
}

Samples samples_for_fit(int64_t width, int64_t height, const at::Tensor& rays,
                        const at::Tensor& valid, int64_t max_samples, const char* what) {
  check_shapes(what, width, height, rays, valid);
  auto samples = sample_valid_pixels(rays, valid, width, max_samples);
  if (samples.rays.size(0) < 16) {
    throw std::invalid_argument(std::string(what) + ": needs at least 16 valid rays, got " +
                                std::to_string(samples.rays.size(0)));
  }
  return samples;
}

// Levenberg-Marquardt on the reprojection error of the samples (fit.h).
// Starts from `start` when given, else from the pinhole guess.
Camera fit_samples(const std::string& model_name, ImageSize size, const Samples& samples,
                   int max_iterations = 100, const std::vector<double>* start = nullptr) {
  const auto& model = find_camera_model(model_name);
  const int64_t width = size.width, height = size.height;
  std::vector<double> params;
  if (start) {
    params = *start;
  } else {
    const auto guess = pinhole_guess(samples, size);
    params = model.initial_params(guess[0], guess[1], guess[2], guess[3], size);
  }

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
  for (int iteration = 0; iteration < max_iterations && count > 0; ++iteration) {
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

// The angle in degrees between the camera's ray at each sample pixel and the sample's ray;
// 180 where the camera has none.
at::Tensor angles_deg(const Camera& camera, const Samples& samples) {
  const Rays own = camera.unproject(samples.pixels);
  const auto cosine = (own.rays * samples.rays).sum(-1).clamp(-1.0, 1.0);
  return at::where(own.valid, at::acos(cosine) * (180.0 / M_PI), at::full_like(cosine, 180.0));
}

AngularResidual summarise(const at::Tensor& angles) {
  if (angles.numel() == 0) return {};
  return {angles.median().item<double>(), angles.mean().item<double>(),
          angles.max().item<double>()};
}

}  // namespace

Camera fit_camera(const std::string& model_name, int64_t width, int64_t height,
                  const at::Tensor& rays, const at::Tensor& valid, int64_t max_samples) {
  find_camera_model(model_name);  // unknown model -> lists the known ones, before any work
  const auto samples = samples_for_fit(width, height, rays, valid, max_samples, "fit_camera");
  return fit_samples(model_name, {width, height}, samples);
}

AngularResidual angular_residual(const Camera& camera, const at::Tensor& rays,
                                 const at::Tensor& valid, int64_t max_samples) {
  check_shapes("angular_residual", camera.width(), camera.height(), rays, valid);
  return summarise(
      angles_deg(camera, sample_valid_pixels(rays, valid, camera.width(), max_samples)));
}

CameraFit fit_camera_model(const std::string& model, int64_t width, int64_t height,
                           const at::Tensor& rays, const at::Tensor& valid) {
  Camera camera = fit_camera(model, width, height, rays, valid);
  const AngularResidual residual = angular_residual(camera, rays, valid);
  return {std::move(camera), residual};
}

CameraFit fit_camera_model_to_images(const std::string& model, int64_t width, int64_t height,
                                     const at::Tensor& rays, const at::Tensor& valid,
                                     const Camera* start) {
  find_camera_model(model);
  if (start != nullptr &&
      (start->model_name() != model || start->width() != width || start->height() != height))
    throw std::invalid_argument("fit_camera_model_to_images: the start camera is not a " + model +
                                " of " + std::to_string(width) + "x" + std::to_string(height));
  if (rays.dim() != 4 || rays.size(0) < 1 || valid.dim() != 3 || valid.size(0) != rays.size(0))
    throw std::invalid_argument(
        "fit_camera_model_to_images: expects rays (N, H, W, 3) and valid (N, H, W), N >= 1");
  const int64_t images = rays.size(0);
  // Each image's even subsample of its share, concatenated: one set of samples.
  const auto samples_of = [&](int64_t total) {
    std::vector<at::Tensor> sample_rays, sample_pixels;
    for (int64_t i = 0; i < images; ++i) {
      check_shapes("fit_camera_model_to_images", width, height, rays[i], valid[i]);
      const Samples each =
          sample_valid_pixels(rays[i], valid[i], width, std::max<int64_t>(16, total / images));
      sample_rays.push_back(each.rays);
      sample_pixels.push_back(each.pixels);
    }
    return Samples{at::cat(sample_rays), at::cat(sample_pixels)};
  };
  const Samples samples = samples_of(4096);
  if (samples.rays.size(0) < 16)
    throw std::invalid_argument("fit_camera_model_to_images: needs at least 16 valid rays, got " +
                                std::to_string(samples.rays.size(0)));
  Camera camera = fit_samples(model, {width, height}, samples, 100,
                              start != nullptr ? &start->params() : nullptr);
  const AngularResidual residual = summarise(angles_deg(camera, samples_of(16384)));
  return {std::move(camera), residual};
}

std::vector<std::string> auto_fit_candidates(double max_angle_deg) {
  std::vector<std::string> names;
  if (max_angle_deg < 80) names.emplace_back("PINHOLE");
  if (max_angle_deg >= 60) names.emplace_back("EQUIRECTANGULAR");
  if (max_angle_deg < 150) names.emplace_back("UCM");
  if (max_angle_deg < 150) names.emplace_back("OPENCV_FISHEYE");
  return names;
}

CameraFit fit_camera_auto(int64_t width, int64_t height, const at::Tensor& rays,
                          const at::Tensor& valid) {
  // The rule's numbers (fit.h).
  constexpr int64_t kScoringSamples = 1024;
  constexpr int kScoringIterations = 20;
  constexpr double kGoodEnoughDeg = 0.1;
  constexpr double kRelativeTolerance = 0.1;
  const auto samples = samples_for_fit(width, height, rays, valid, 4096, "fit_camera_auto");
  const auto scoring = sample_valid_pixels(rays, valid, width, kScoringSamples);
  const double max_angle_deg =
      std::acos(std::clamp(samples.rays.select(-1, 2).min().item<double>(), -1.0, 1.0)) * 180.0 /
      M_PI;
  struct Scored {
    Camera camera;
    double mean_deg;
  };
  std::vector<Scored> scored;
  std::string failures;
  for (const std::string& name : auto_fit_candidates(max_angle_deg)) {
    try {
      Camera camera = fit_samples(name, {width, height}, scoring, kScoringIterations);
      const double mean_deg = angles_deg(camera, scoring).mean().item<double>();
      scored.push_back({std::move(camera), mean_deg});
      if (mean_deg < kGoodEnoughDeg) break;
    } catch (const std::invalid_argument& e) {
      failures += std::string(failures.empty() ? "" : "; ") + e.what();
    }
  }
  if (scored.empty())
    throw std::invalid_argument("fit_camera_auto: no candidate model fits the rays: " + failures);
  double lowest_deg = scored.front().mean_deg;
  for (const Scored& each : scored) lowest_deg = std::min(lowest_deg, each.mean_deg);
  const double tolerance_deg = std::max(kGoodEnoughDeg, kRelativeTolerance * lowest_deg);
  const auto chosen = std::find_if(scored.begin(), scored.end(), [&](const Scored& each) {
    return each.mean_deg <= lowest_deg + tolerance_deg;  // the lowest itself qualifies
  });
  Camera camera = fit_samples(chosen->camera.model_name(), {width, height}, samples, 100,
                              &chosen->camera.params());
  const AngularResidual residual = angular_residual(camera, rays, valid);
  return {std::move(camera), residual};
}

}  // namespace omnipoint::camera
