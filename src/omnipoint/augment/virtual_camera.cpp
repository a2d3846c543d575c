#include "omnipoint/augment/virtual_camera.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

#include "omnipoint/augment/warp.h"

namespace omnipoint::augment {
namespace {

double uniform(at::Generator& generator, double lo, double hi) {
  return lo + (hi - lo) * at::rand({1}, generator, at::kDouble).item<double>();
}

int64_t pick(const std::vector<double>& weights, at::Generator& generator) {
  const double total = std::accumulate(weights.begin(), weights.end(), 0.0);
  if (weights.empty() || !(total > 0) ||
      std::any_of(weights.begin(), weights.end(), [](double w) { return !(w >= 0); })) {
    throw std::invalid_argument(
        "virtual camera distribution: weights must be non-negative with a positive sum");
  }
  double u = uniform(generator, 0.0, total);
  for (std::size_t i = 0; i < weights.size(); ++i) {
    if (u < weights[i]) return static_cast<int64_t>(i);
    u -= weights[i];
  }
  return static_cast<int64_t>(weights.size()) - 1;
}

}  // namespace

camera::Camera fisheye_with_fov(const std::string& model, int64_t width, int64_t height,
                                double fov_deg, const std::vector<double>& shape) {
  if (!(fov_deg > 0 && fov_deg < 360))
    throw std::invalid_argument("fisheye_with_fov: the FoV must be in (0, 360) degrees");
  const double cx = width / 2.0, cy = height / 2.0;
  std::vector<double> unit_params{1.0, 1.0, cx, cy};
  unit_params.insert(unit_params.end(), shape.begin(), shape.end());
  const camera::Camera unit(model, width, height, unit_params);
  // The projected radius of rays from the axis to the rim must grow monotonically: the
  // image circle then holds exactly the directions within fov / 2.
  const double half = fov_deg * M_PI / 360.0;
  const at::Tensor theta = at::linspace(half / 64, half, 64, at::kDouble);
  const at::Tensor rays = at::stack({at::sin(theta), at::zeros_like(theta), at::cos(theta)}, -1);
  const camera::Pixels projected = unit.project(rays);
  const at::Tensor radius = projected.pixels.select(-1, 0) - cx;
  const bool monotonic = projected.valid.all().item<bool>() &&
                         (radius.narrow(0, 1, 63) > radius.narrow(0, 0, 63)).all().item<bool>() &&
                         (radius > 0).all().item<bool>();
  if (!monotonic) {
    throw std::invalid_argument("fisheye_with_fov: " + model +
                                " with these parameters does not see " + std::to_string(fov_deg) +
                                " degrees");
  }
  const double focal = std::min(width, height) / 2.0 / radius[63].item<double>();
  std::vector<double> params{focal, focal, cx, cy};
  params.insert(params.end(), shape.begin(), shape.end());
  return camera::Camera(model, width, height, params);
}

VirtualView sample_virtual_view(const VirtualCameraDistribution& d, at::Generator generator) {
  if (d.weights.size() != 6)
    throw std::invalid_argument("virtual camera distribution: expected 6 weights");
  const int64_t kind = pick(d.weights, generator);
  const double yaw = uniform(generator, -d.max_yaw_deg, d.max_yaw_deg);
  const double pitch = uniform(generator, -d.max_pitch_deg, d.max_pitch_deg);
  const double roll = uniform(generator, -d.max_roll_deg, d.max_roll_deg);
  if (kind == 4) {  // full panorama: any heading, kept level (panoramas are stored upright)
    const camera::Camera pano("EQUIRECTANGULAR", d.panorama_width, d.panorama_width / 2, {});
    return {pano, rotation_from_angles(uniform(generator, -180, 180), 0.0), {}};
  }
  if (kind == 5) {
    const double lon = uniform(generator, d.min_crop_lon_deg, d.max_crop_lon_deg) * M_PI / 180;
    const double lat = uniform(generator, d.min_crop_lat_deg, d.max_crop_lat_deg) * M_PI / 180;
    const int64_t width = d.panorama_width;
    const int64_t height = std::max<int64_t>(8, std::llround(width * lat / lon));
    const camera::Camera crop("EQUIRECTANGULAR", width, height,
                              {-lon / 2, lon / 2, -lat / 2, lat / 2});
    return {crop, rotation_from_angles(yaw, pitch, roll), {}};
  }
  const double fov = uniform(generator, d.min_fisheye_fov_deg, d.max_fisheye_fov_deg);
  std::string model;
  std::vector<double> shape;
  if (kind == 0) {
    model = "OPENCV_FISHEYE";
    shape = {uniform(generator, -0.02, 0.02), 0.0, 0.0, 0.0};
  } else if (kind == 1) {
    model = "MEI";
    shape = {uniform(generator, 0.8, 1.2), uniform(generator, -0.02, 0.02), 0.0, 0.0, 0.0};
  } else if (kind == 2) {
    model = "EUCM";
    shape = {uniform(generator, 0.5, 0.65), uniform(generator, 0.9, 1.1)};
  } else {
    model = "DOUBLE_SPHERE";
    shape = {uniform(generator, -0.2, 0.2), uniform(generator, 0.5, 0.65)};
  }
  return {fisheye_with_fov(model, d.fisheye_size, d.fisheye_size, fov, shape),
          rotation_from_angles(yaw, pitch, roll),
          {}};
}

std::vector<bool> select_items(int64_t batch_size, double probability, at::Generator generator) {
  if (batch_size < 0 || !(probability >= 0 && probability <= 1)) {
    throw std::invalid_argument("select_items: need batch_size >= 0 and probability in [0, 1]");
  }
  const at::Tensor u = at::rand({batch_size}, generator, at::kDouble);
  std::vector<bool> selected(batch_size);
  for (int64_t i = 0; i < batch_size; ++i) selected[i] = u[i].item<double>() < probability;
  return selected;
}

}  // namespace omnipoint::augment
