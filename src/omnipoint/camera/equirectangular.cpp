// EQUIRECTANGULAR: a 360 x 180 degree panorama (no parameters) or a cropped one with
// lon_min lon_max lat_min lat_max in radians. Longitude (azimuth) is measured from +z towards
// +x, latitude (elevation) is up positive (docs/DESIGN.md):
//   ray = (cos(lat) sin(lon), -sin(lat), cos(lat) cos(lon)),
//   x in [0, W] maps linearly to [lon_min, lon_max], y in [0, H] to [lat_max, lat_min];
// the full panorama is lon in [-pi, pi], lat in [-pi/2, pi/2]. Every direction projects;
// longitudes wrap around the centre of the longitude range, so a crop across the seam works.
#include <ATen/ATen.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

#include "omnipoint/camera/camera_model.h"
#include "omnipoint/camera/lens_helpers.h"

namespace omnipoint::camera {
namespace {

struct Bounds {
  double lon_min, lon_max, lat_min, lat_max;
};

Bounds bounds_of(const std::vector<double>& params) {
  if (params.empty()) return {-M_PI, M_PI, -M_PI / 2, M_PI / 2};
  return {params[0], params[1], params[2], params[3]};
}

Bounds bounds_of(const at::Tensor& params) {
  return bounds_of(host_values(params));
}

class EquirectangularModel final : public CameraModel {
 public:
  std::string name() const override { return "EQUIRECTANGULAR"; }
  std::vector<std::string> param_names() const override {
    return {"lon_min", "lon_max", "lat_min", "lat_max"};
  }
  bool accepts_param_count(std::size_t count) const override { return count == 0 || count == 4; }
  std::string expected_params() const override {
    return "0 parameters (a full panorama) or 4 (lon_min lon_max lat_min lat_max, radians)";
  }

  void check_params(const std::vector<double>& params, ImageSize) const override {
    if (params.empty()) return;
    const Bounds b = bounds_of(params);
    std::ostringstream text;
    text.precision(17);
    if (!(b.lon_min < b.lon_max && b.lon_max - b.lon_min <= 2 * M_PI + 1e-9)) {
      text << "EQUIRECTANGULAR: expects lon_min < lon_max <= lon_min + 2 pi, got " << b.lon_min
           << " " << b.lon_max;
    } else if (!(-M_PI / 2 - 1e-9 <= b.lat_min && b.lat_min < b.lat_max &&
                 b.lat_max <= M_PI / 2 + 1e-9)) {
      text << "EQUIRECTANGULAR: expects -pi/2 <= lat_min < lat_max <= pi/2, got " << b.lat_min
           << " " << b.lat_max;
    } else {
      return;
    }
    throw std::invalid_argument(text.str());
  }

  Pixels project(const at::Tensor& params, ImageSize size,
                 const at::Tensor& points) const override {
    const Bounds b = bounds_of(params);
    const auto x = points.select(-1, 0);
    const auto y = points.select(-1, 1);
    const auto z = points.select(-1, 2);
    const auto horizontal = at::sqrt(x * x + z * z);
    const auto valid = (horizontal > 0) | (y != 0);
    const double centre = 0.5 * (b.lon_min + b.lon_max);
    auto lon = at::atan2(x, z);
    lon = lon - 2 * M_PI * at::floor((lon - (centre - M_PI)) / (2 * M_PI));
    const auto lat = at::atan2(-y, horizontal);
    const auto pixels = at::stack({(lon - b.lon_min) * (size.width / (b.lon_max - b.lon_min)),
                                   (b.lat_max - lat) * (size.height / (b.lat_max - b.lat_min))},
                                  -1);
    return {at::where(valid.unsqueeze(-1), pixels, at::zeros_like(pixels)), valid};
  }

  Rays unproject(const at::Tensor& params, ImageSize size,
                 const at::Tensor& pixels) const override {
    const Bounds b = bounds_of(params);
    const auto lon = b.lon_min + pixels.select(-1, 0) * ((b.lon_max - b.lon_min) / size.width);
    const auto unclamped_lat =
        b.lat_max - pixels.select(-1, 1) * ((b.lat_max - b.lat_min) / size.height);
    // The poles themselves are valid despite rounding (float32 pi/2 exceeds pi/2).
    const auto valid = unclamped_lat.abs() <= M_PI / 2 * (1 + 1e-6);
    const auto lat = unclamped_lat.clamp(-M_PI / 2, M_PI / 2);
    const auto cos_lat = at::cos(lat);
    const auto rays =
        at::stack({cos_lat * at::sin(lon), -at::sin(lat), cos_lat * at::cos(lon)}, -1);
    return {at::where(valid.unsqueeze(-1), rays, at::zeros_like(rays)), valid};
  }

  // The angular extent per pixel does not change with the image size.
  std::vector<double> scaled_params(const std::vector<double>& params, double,
                                    double) const override {
    return params;
  }

  std::vector<double> cropped_params(const std::vector<double>& params, ImageSize size, double x0,
                                     double y0, ImageSize new_size) const override {
    const Bounds b = bounds_of(params);
    const double lon_per_px = (b.lon_max - b.lon_min) / size.width;
    const double lat_per_px = (b.lat_max - b.lat_min) / size.height;
    const double lat_max = b.lat_max - y0 * lat_per_px;
    return {b.lon_min + x0 * lon_per_px, b.lon_min + (x0 + new_size.width) * lon_per_px,
            lat_max - new_size.height * lat_per_px, lat_max};
  }

  std::vector<double> initial_params(double, double, double, double, ImageSize) const override {
    const Bounds b = bounds_of(std::vector<double>{});
    return {b.lon_min, b.lon_max, b.lat_min, b.lat_max};
  }
};

}  // namespace

const CameraModel& equirectangular_model() {
  static const EquirectangularModel model;
  return model;
}

}  // namespace omnipoint::camera
