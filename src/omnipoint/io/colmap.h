#pragma once
// COLMAP sparse reconstructions: the folder COLMAP writes (`sparse/0`) with cameras, images
// and points3D, each as .bin or .txt in COLMAP's formats (where both exist the .bin is read,
// as COLMAP itself prefers it; rigs and frames files are not needed: images hold each
// camera's pose).
// - Cameras: every classic COLMAP model (ids 0..11), EUCM (16) and EQUIRECTANGULAR (17, its
//   parameters w h must be the image size: a full panorama). Models COLMAP has that OmniPoint
//   lacks (SIMPLE_DIVISION, DIVISION, SIMPLE_FISHEYE, FISHEYE, or an id it does not know)
//   are an error naming the model.
// - Images: the pose is world-to-camera, X_cam = R(q) X_world + t with q = (qw, qx, qy, qz),
//   normalised on reading; the camera frame is COLMAP's and ours (x right, y down, z forward).
//   Each image's 2-D observations and the 3-D point each one belongs to (-1: none; COLMAP
//   writes -1 in text and 2^64 - 1 in binary).
// - Points: world position, colour and reprojection error; the tracks are not kept (images
//   hold the same links).
// Content that is not what the format promises (bad numbers, truncated binary data, counts
// larger than the bytes that hold them, zero or non-finite quaternions, non-finite values,
// duplicate ids, an image's camera or point id that the model lacks) raises
// std::invalid_argument, a missing or unreadable file std::runtime_error; each names the file.
#include <ATen/core/Tensor.h>

#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"

namespace omnipoint::io {

struct ColmapImage {
  int64_t id = 0;
  int64_t camera_id = 0;
  std::string name;
  std::array<double, 4> qvec{1, 0, 0, 0};  // w, x, y, z; unit length
  std::array<double, 3> tvec{0, 0, 0};
  std::vector<std::array<double, 2>> points2d;  // pixels, COLMAP's (0, 0) = image corner
  std::vector<int64_t> point3d_ids;             // one per point2d; -1 = none
};

struct ColmapPoint {
  std::array<double, 3> xyz{0, 0, 0};
  std::array<uint8_t, 3> rgb{0, 0, 0};
  double error = 0;
};

struct ColmapModel {
  std::map<int64_t, camera::Camera> cameras;
  std::vector<ColmapImage> images;  // in file order
  std::map<int64_t, ColmapPoint> points;
};

// The model in `folder`; checks that the images' camera and point ids exist.
ColmapModel read_colmap_model(const std::string& folder);

// One file's content (the text or bytes of cameras, images or points3D); `name` names it in
// errors. These check each file on its own.
std::map<int64_t, camera::Camera> parse_colmap_cameras_text(const std::string& text,
                                                            const std::string& name);
std::map<int64_t, camera::Camera> parse_colmap_cameras_binary(const std::string& bytes,
                                                              const std::string& name);
std::vector<ColmapImage> parse_colmap_images_text(const std::string& text, const std::string& name);
std::vector<ColmapImage> parse_colmap_images_binary(const std::string& bytes,
                                                    const std::string& name);
std::map<int64_t, ColmapPoint> parse_colmap_points_text(const std::string& text,
                                                        const std::string& name);
std::map<int64_t, ColmapPoint> parse_colmap_points_binary(const std::string& bytes,
                                                          const std::string& name);

// (4, 4) float64 camera-from-world transform [R(q) | t] of an image.
at::Tensor camera_from_world(const ColmapImage& image);

}  // namespace omnipoint::io
