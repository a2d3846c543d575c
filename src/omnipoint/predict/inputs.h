#pragma once
// Reading the user's sparse depth files (the `--sparse-depth` inputs of `omnipoint predict`):
//   *.png           16-bit (or 8-bit) grey depth image, planar depth z; the stored value divided
//                   by `depth_png_units_per_metre` is metres (1000: millimetres, the default;
//                   256: KITTI depth completion / depth prediction PNGs)
//   *.npy           (H, W) float depth in metres, planar depth z
//   *.exr           32-bit float depth in metres (only where OpenCV's EXR codec is enabled)
//   *.ply, *.pcd    point cloud in metres (x, y, z; other properties ignored; io/ply.h, io/pcd.h)
//   *.bin           LiDAR scan of float32 records, x, y, z first (`lidar_floats_per_point`: 4 for
//                   KITTI Velodyne x y z intensity, 5 for nuScenes x y z intensity ring)
// Zero (or non-finite) depth means "no sample". Point clouds are in the LiDAR frame; the
// camera-from-LiDAR transform is read by io::read_rigid_transform (a 4x4 or 3x4 text file, a
// KITTI calibration file, or a .npy). Without one the cloud is taken as in the camera frame.
// Errors: std::runtime_error for unreadable files, std::invalid_argument for content that
// is not what the format promises; each names the file.
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/io/exif.h"
#include "omnipoint/predict/predictor.h"

namespace omnipoint::predict {

struct SparseDepthFileOptions {
  double depth_png_units_per_metre = 1000.0;
  int64_t lidar_floats_per_point = 4;
  // (4, 4) io::read_rigid_transform, read once for all images; undefined: the cloud is in the
  // camera frame.
  at::Tensor camera_from_lidar;
};

SparseDepthInput read_sparse_depth(const std::string& path,
                                   const SparseDepthFileOptions& options = {});

// Whether `path` is one of the point-cloud formats above (rather than a depth map).
bool is_point_cloud_file(const std::string& path);

// The extensions a sparse-depth folder is searched for, in order of preference.
const std::vector<std::string>& sparse_depth_extensions();

// A photo's camera from its EXIF focal length: a pinhole of square pixels centred in the image
// as displayed (width x height, after the EXIF orientation), of focal length f pixels:
//  - from FocalLengthIn35mmFilm F35 when there is one. The 35 mm equivalent focal length is
//    the one giving the same diagonal angle of view on a 36 x 24 mm frame (CIPA's guideline
//    DCG-001, the usual reading), so f = F35 · √(W² + H²) / √(36² + 24²), whatever the aspect
//    ratio and the orientation;
//  - else from FocalLength F with the sensor's pixel density (FocalPlaneXResolution and its
//    unit), which counts pixels of an image PixelXDimension wide (default: as stored):
//    f = F · pixels per mm · (stored width / PixelXDimension), so a photo resized since keeps
//    its field of view.
// nullopt when EXIF gives neither, or (with *rejected set to why) a horizontal field of view
// outside [1, 160] degrees, which no pinhole photo has (a unit written wrong).
struct ExifCamera {
  camera::Camera camera;
  std::string description;  // "35 mm equivalent focal length 26 mm", "focal length 4.2 mm ..."
};
std::optional<ExifCamera> camera_from_exif(const io::ExifFacts& facts, int64_t width,
                                           int64_t height, std::string* rejected = nullptr);

// --max-size: the size of a width x height image whose long side is at most max_size (0: no
// limit), the aspect ratio kept (sides rounded, at least 1).
camera::ImageSize size_within(int64_t width, int64_t height, int64_t max_size);
// An image (H, W, 3) (float in [0, 1] or uint8) at width x height: anti-aliased bilinear (no
// aliasing when shrinking by large factors). The camera needs no counterpart: predict resizes a
// camera of the image's aspect ratio itself (Camera::resized).
at::Tensor resize_image(const at::Tensor& image, int64_t width, int64_t height);
// An input image decoded (turned as its EXIF orientation says when use_exif) and brought to
// the network's size (size_within max_size): what predict hands the network.
struct DecodedImage {
  at::Tensor image;                 // (H, W, 3) at `size`
  camera::ImageSize original_size;  // as decoded and turned
  camera::ImageSize size;
  io::ExifFacts exif;  // none unless read
  double decode_ms = 0;
};
DecodedImage read_input_image(const std::string& path, int64_t max_size, bool use_exif);
// The sparse depth of an image_width x image_height image at width x height, with the image:
// depth maps (which must be at the image's size) through geometry::resize_sparse_map (no sample
// lost or blended); point clouds unchanged (they are projected at the new size).
SparseDepthInput resize_sparse_depth(const SparseDepthInput& input, int64_t image_width,
                                     int64_t image_height, int64_t width, int64_t height);

}  // namespace omnipoint::predict
