// UniK3D's camera classes as our models (the table in unik3d.h).
#include "omnipoint/camera/unik3d.h"

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace omnipoint::camera {
namespace {

// Whether params[first, last) are all zero.
bool all_zero(const std::vector<double>& params, std::size_t first, std::size_t last) {
  for (std::size_t i = first; i < last; ++i) {
    if (params[i] != 0) return false;
  }
  return true;
}

void require_count(const std::string& class_name, const std::vector<double>& params,
                   std::size_t count, const std::string& names) {
  if (params.size() != count) {
    throw std::invalid_argument("UniK3D " + class_name + " expects " + std::to_string(count) +
                                " params (" + names + "), got " + std::to_string(params.size()));
  }
}

void refuse(const std::string& class_name, const std::string& why) {
  throw std::invalid_argument("UniK3D " + class_name + ": " + why);
}

ImageSize size_or_refuse(const std::string& class_name, std::optional<ImageSize> image_size) {
  if (!image_size) {
    refuse(class_name,
           "the file holds no image size; add \"width\" and \"height\" to it, or pass the image's "
           "size");
  }
  return *image_size;
}

// UniK3D's OPENCV and MEI apply the tangential terms after the radial ones; ours beside them.
void refuse_radial_with_tangential(const std::string& class_name, const std::string& radial,
                                   const std::string& tangential) {
  refuse(class_name, "both radial (" + radial + ") and tangential (" + tangential +
                         ") terms are non-zero; UniK3D applies the tangential terms to the "
                         "radially distorted point, our models (as OpenCV) to the undistorted "
                         "one, so only one of them can be represented exactly");
}

Camera from_opencv(const std::vector<double>& p, ImageSize size) {
  require_count("OPENCV", p, 16, "fx fy cx cy k1 k2 k3 k4 k5 k6 p1 p2 s1 s2 s3 s4");
  if (!all_zero(p, 12, 16))
    refuse("OPENCV", "thin-prism terms s1..s4 are non-zero; none of our pinhole models has them");
  if (!all_zero(p, 7, 10))
    refuse("OPENCV", "the rational terms k4..k6 are non-zero (UniK3D's OPENCV refuses them too)");
  if (!all_zero(p, 4, 7) && !all_zero(p, 10, 12))
    refuse_radial_with_tangential("OPENCV", "k1 k2 k3", "p1 p2");
  const double fx = p[0], fy = p[1], cx = p[2], cy = p[3], k1 = p[4], k2 = p[5], k3 = p[6];
  // UniK3D's p1 multiplies r² + 2x² in x: OpenCV's p2.
  const double opencv_p1 = p[11], opencv_p2 = p[10];
  if (k3 != 0) {
    return Camera("FULL_OPENCV", size.width, size.height,
                  {fx, fy, cx, cy, k1, k2, opencv_p1, opencv_p2, k3, 0, 0, 0});
  }
  return Camera("OPENCV", size.width, size.height, {fx, fy, cx, cy, k1, k2, opencv_p1, opencv_p2});
}

Camera from_fisheye624(const std::vector<double>& p, ImageSize size) {
  require_count("Fisheye624", p, 16, "fx fy cx cy k0 k1 k2 k3 k4 k5 p0 p1 s0 s1 s2 s3");
  if (all_zero(p, 8, 16)) {
    return Camera("OPENCV_FISHEYE", size.width, size.height,
                  {p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7]});
  }
  return Camera("RAD_TAN_THIN_PRISM_FISHEYE", size.width, size.height, p);
}

Camera from_mei(const std::vector<double>& p, ImageSize size) {
  require_count("MEI", p, 9, "fx fy cx cy k1 k2 p1 p2 xi");
  if (!all_zero(p, 4, 6) && !all_zero(p, 6, 8))
    refuse_radial_with_tangential("MEI", "k1 k2", "p1 p2");
  const double fx = p[0], fy = p[1], cx = p[2], cy = p[3], k1 = p[4], k2 = p[5], xi = p[8];
  const double opencv_p1 = p[7], opencv_p2 = p[6];
  return Camera("MEI", size.width, size.height, {fx, fy, cx, cy, xi, k1, k2, opencv_p1, opencv_p2});
}

Camera from_spherical(const std::vector<double>& p) {
  require_count("Spherical", p, 8, "fx fy cx cy W H hfov/2 vfov/2");
  const double width = p[4], height = p[5], half_hfov = p[6], half_vfov = p[7];
  if (!(width >= 1 && height >= 1 && width == std::floor(width) && height == std::floor(height) &&
        width < 1e9 && height < 1e9)) {
    std::ostringstream text;
    text << "the image size W H (params 5 and 6) must be positive integers, got " << width << " "
         << height;
    refuse("Spherical", text.str());
  }
  return Camera("EQUIRECTANGULAR", static_cast<int64_t>(width), static_cast<int64_t>(height),
                {-half_hfov, half_hfov, -half_vfov, half_vfov});
}

}  // namespace

Camera camera_from_unik3d(const std::string& class_name, const std::vector<double>& params,
                          std::optional<ImageSize> image_size) {
  if (class_name == "Spherical") return from_spherical(params);
  if (class_name == "Pinhole") {
    require_count("Pinhole", params, 4, "fx fy cx cy");
    const ImageSize size = size_or_refuse(class_name, image_size);
    return Camera("PINHOLE", size.width, size.height, params);
  }
  if (class_name == "EUCM") {
    require_count("EUCM", params, 6, "fx fy cx cy alpha beta");
    const ImageSize size = size_or_refuse(class_name, image_size);
    return Camera("EUCM", size.width, size.height, params);
  }
  if (class_name == "OPENCV") return from_opencv(params, size_or_refuse(class_name, image_size));
  if (class_name == "Fisheye624")
    return from_fisheye624(params, size_or_refuse(class_name, image_size));
  if (class_name == "MEI") return from_mei(params, size_or_refuse(class_name, image_size));
  throw std::invalid_argument("unknown UniK3D camera class '" + class_name +
                              "'; known: Pinhole OPENCV Fisheye624 MEI EUCM Spherical");
}

}  // namespace omnipoint::camera
