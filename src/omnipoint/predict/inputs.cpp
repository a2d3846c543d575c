// Sparse depth files -> SparseDepthInput (formats in inputs.h).
#include "omnipoint/predict/inputs.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/io/file_name.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/point_cloud.h"

namespace omnipoint::predict {

namespace {

at::Tensor depth_map(const std::string& path, const std::string& ext,
                     double depth_png_units_per_metre) {
  if (ext == ".npy") {
    at::Tensor depth = io::read_npy(path);
    if (!at::isFloatingType(depth.scalar_type()))
      throw std::invalid_argument("sparse depth " + path +
                                  ": expected float depth in metres, got dtype " +
                                  std::string(c10::toString(depth.scalar_type())));
    return depth;
  }
  try {
    const at::Tensor values = io::read_image_values(path);
    return ext == ".png" ? values / depth_png_units_per_metre : values;
  } catch (const std::runtime_error& e) {
    if (ext != ".exr") throw;
    // OpenCV builds EXR support in but disables it unless OPENCV_IO_ENABLE_OPENEXR is set.
    throw std::runtime_error(
        "sparse depth " + path + ": OpenCV could not decode this EXR (" + e.what() +
        "); its EXR codec is off unless OPENCV_IO_ENABLE_OPENEXR=1 is set, or pass .npy");
  }
}

}  // namespace

const std::vector<std::string>& sparse_depth_extensions() {
  static const std::vector<std::string> extensions = {".png", ".npy", ".exr",
                                                      ".ply", ".pcd", ".bin"};
  return extensions;
}

bool is_point_cloud_file(const std::string& path) {
  return io::is_point_cloud_file(path);
}

SparseDepthInput read_sparse_depth(const std::string& path, const SparseDepthFileOptions& options) {
  if (!std::filesystem::is_regular_file(path))
    throw std::runtime_error("sparse depth " + path + ": no such file");
  if (!(options.depth_png_units_per_metre > 0) || !std::isfinite(options.depth_png_units_per_metre))
    throw std::invalid_argument("sparse depth: the depth PNG scale must be a positive number");
  const std::string ext = io::lower_extension(path);
  SparseDepthInput input;
  if (is_point_cloud_file(path)) {
    input.lidar_points = io::read_point_cloud(path, options.lidar_floats_per_point, "sparse depth");
    input.camera_from_lidar = options.camera_from_lidar;
    return input;
  }
  if (ext != ".png" && ext != ".exr" && ext != ".npy")
    throw std::invalid_argument("sparse depth " + path +
                                ": unknown format (expected a depth map .png, .npy or .exr, or a "
                                "point cloud .ply, .pcd or .bin)");
  if (options.camera_from_lidar.defined())
    throw std::invalid_argument("sparse depth " + path +
                                ": --lidar-to-camera applies to point clouds only");
  const at::Tensor depth = depth_map(path, ext, options.depth_png_units_per_metre);
  if (depth.dim() != 2)
    throw std::invalid_argument("sparse depth " + path +
                                ": expected a single-channel (H, W) map, got " +
                                c10::str(depth.sizes()));
  input.depth_map = depth.to(at::kFloat);
  input.depth_is_planar = true;
  return input;
}

std::optional<ExifCamera> camera_from_exif(const io::ExifFacts& facts, int64_t width,
                                           int64_t height, std::string* rejected) {
  const auto number = [](double value) {
    std::ostringstream text;
    text << std::setprecision(4) << value;
    return text.str();
  };
  double focal = 0;
  std::string description;
  if (facts.focal_length_35mm) {
    const double film_diagonal_mm = std::hypot(36.0, 24.0);
    focal = *facts.focal_length_35mm * std::hypot(width, height) / film_diagonal_mm;
    description = "35 mm equivalent focal length " + number(*facts.focal_length_35mm) + " mm";
  } else if (facts.focal_length && facts.focal_plane_pixels_per_mm) {
    const int64_t stored_width = io::orientation_swaps_axes(facts.orientation) ? height : width;
    const double reference_width =
        facts.pixel_x_dimension ? static_cast<double>(*facts.pixel_x_dimension) : stored_width;
    focal = *facts.focal_length * *facts.focal_plane_pixels_per_mm * stored_width / reference_width;
    description = "focal length " + number(*facts.focal_length) + " mm on a sensor of " +
                  number(*facts.focal_plane_pixels_per_mm) + " pixels/mm";
  } else {
    return std::nullopt;
  }
  const double fov_deg = 2.0 * std::atan(0.5 * width / focal) * 180.0 / M_PI;
  if (!(fov_deg >= 1.0 && fov_deg <= 160.0)) {
    if (rejected != nullptr)
      *rejected = "the EXIF " + description + " gives a horizontal field of view of " +
                  number(fov_deg) + " degrees: ignored";
    return std::nullopt;
  }
  const std::string camera =
      facts.make.empty() && facts.model.empty()
          ? ""
          : " (" + facts.make + (facts.make.empty() ? "" : " ") + facts.model + ")";
  return ExifCamera{
      camera::Camera("PINHOLE", width, height, {focal, focal, 0.5 * width, 0.5 * height}),
      description + camera};
}

camera::ImageSize size_within(int64_t width, int64_t height, int64_t max_size) {
  const int64_t long_side = std::max(width, height);
  if (max_size <= 0 || long_side <= max_size) return {width, height};
  const double scale = static_cast<double>(max_size) / long_side;
  return {std::max<int64_t>(1, std::llround(width * scale)),
          std::max<int64_t>(1, std::llround(height * scale))};
}

at::Tensor resize_image(const at::Tensor& image, int64_t width, int64_t height) {
  if (image.dim() != 3 || image.size(2) != 3)
    throw std::invalid_argument("resize_image: expected an image (H, W, 3), got " +
                                c10::str(image.sizes()));
  if (image.size(0) == height && image.size(1) == width) return image;
  const bool bytes = image.scalar_type() == at::kByte;
  const at::Tensor chw = image.to(at::kFloat).permute({2, 0, 1}).unsqueeze(0);
  at::Tensor resized = at::_upsample_bilinear2d_aa(chw, {height, width}, /*align_corners=*/false)
                           .squeeze(0)
                           .permute({1, 2, 0});
  resized = bytes ? resized.round().clamp(0, 255).to(at::kByte) : resized.clamp(0, 1);
  return resized.contiguous();
}

SparseDepthInput resize_sparse_depth(const SparseDepthInput& input, int64_t image_width,
                                     int64_t image_height, int64_t width, int64_t height) {
  if (!input.depth_map.defined() || (image_width == width && image_height == height)) return input;
  if (input.depth_map.dim() != 2 || input.depth_map.size(0) != image_height ||
      input.depth_map.size(1) != image_width)
    throw std::invalid_argument("sparse depth: the map is " + c10::str(input.depth_map.sizes()) +
                                " but the image is " + std::to_string(image_height) + "x" +
                                std::to_string(image_width) + " (H x W)");
  SparseDepthInput resized = input;
  resized.depth_map = geometry::resize_sparse_map(input.depth_map, width, height);
  return resized;
}

DecodedImage read_input_image(const std::string& path, int64_t max_size, bool use_exif) {
  const auto start = std::chrono::steady_clock::now();
  DecodedImage decoded;
  if (use_exif) decoded.exif = io::read_exif(path);
  const at::Tensor original =
      io::apply_exif_orientation(io::read_image(path), decoded.exif.orientation);
  decoded.original_size = {original.size(1), original.size(0)};
  decoded.size = size_within(original.size(1), original.size(0), max_size);
  decoded.image = resize_image(original, decoded.size.width, decoded.size.height);
  decoded.decode_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return decoded;
}

}  // namespace omnipoint::predict
