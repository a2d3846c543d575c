#include "omnipoint/io/colmap_records.h"

#include <cmath>
#include <stdexcept>
#include <utility>

namespace omnipoint::io::colmap_records {
namespace {

// Normalises the quaternion; zero or non-finite ones are errors.
void normalise_quaternion(ColmapImage& image, const std::string& name) {
  double norm = 0;
  for (const double q : image.qvec) norm += q * q;
  norm = std::sqrt(norm);
  if (!(norm > 0) || !std::isfinite(norm))
    fail(name, "image " + std::to_string(image.id) + ": the quaternion is zero or not finite");
  for (double& q : image.qvec) q /= norm;
}

void check_finite(const double* values, size_t count, const std::string& what,
                  const std::string& name) {
  for (size_t i = 0; i < count; ++i)
    if (!std::isfinite(values[i])) fail(name, what + " is not finite");
}

}  // namespace

void fail(const std::string& name, const std::string& what) {
  throw std::invalid_argument("COLMAP " + name + ": " + what);
}

void check_supported(const std::string& model, const std::string& name, const std::string& where) {
  if (model == "SIMPLE_DIVISION" || model == "DIVISION" || model == "SIMPLE_FISHEYE" ||
      model == "FISHEYE")
    fail(name, where + ": COLMAP's camera model " + model +
                   " is not supported by OmniPoint (undistort the images with COLMAP's "
                   "image_undistorter, or choose another model)");
}

camera::Camera colmap_camera(const std::string& model, int64_t width, int64_t height,
                             std::vector<double> params, const std::string& name,
                             const std::string& where) {
  check_supported(model, name, where);
  if (model == "EQUIRECTANGULAR" && params.size() == kEquirectangularParams) {
    if (params[0] != static_cast<double>(width) || params[1] != static_cast<double>(height))
      fail(name, where + ": EQUIRECTANGULAR parameters w h must be the image size " +
                     std::to_string(width) + " " + std::to_string(height));
    params.clear();
  }
  try {
    return camera::Camera(model, width, height, std::move(params));
  } catch (const std::invalid_argument& error) {
    fail(name, where + ": " + error.what());
  }
}

void add_camera(std::map<int64_t, camera::Camera>& cameras, int64_t id, camera::Camera camera,
                const std::string& name) {
  if (!cameras.emplace(id, std::move(camera)).second)
    fail(name, "the camera id " + std::to_string(id) + " appears twice");
}

void add_image(std::vector<ColmapImage>& images, std::set<int64_t>& ids, ColmapImage image,
               const std::string& name) {
  check_finite(image.qvec.data(), 4, "image " + std::to_string(image.id) + "'s quaternion", name);
  check_finite(image.tvec.data(), 3, "image " + std::to_string(image.id) + "'s translation", name);
  normalise_quaternion(image, name);
  if (!ids.insert(image.id).second)
    fail(name, "the image id " + std::to_string(image.id) + " appears twice");
  images.push_back(std::move(image));
}

void add_point(std::map<int64_t, ColmapPoint>& points, int64_t id, const ColmapPoint& point,
               const std::string& name) {
  check_finite(point.xyz.data(), 3, "point " + std::to_string(id) + "'s position", name);
  if (!std::isfinite(point.error))
    fail(name, "point " + std::to_string(id) + "'s error is not finite");
  if (!points.emplace(id, point).second)
    fail(name, "the point id " + std::to_string(id) + " appears twice");
}

}  // namespace omnipoint::io::colmap_records
