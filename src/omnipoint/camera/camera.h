#pragma once
// A camera as users see it: a model (camera_model.h) with an image size and parameters,
// validated at construction. Conventions (frame, pixel centres, COLMAP parameter orders) are
// those of camera_model.h.
//
// Spec forms accepted by parse_camera (files holding them are read by io/camera_file.h):
//   "PINHOLE 640 480 500 500 320 240"           a COLMAP cameras.txt line (MODEL W H PARAMS...)
//   "1 PINHOLE 640 480 500 500 320 240"         the same with a leading camera id
//   {"model": "PINHOLE", "width": 640, "height": 480, "params": [500, 500, 320, 240]}
//   {"camera": {"model": ...}, ...}             a camera.json written by predict (predict/outputs.h)
//   {"name": "Pinhole", "params": [500, 500, 320, 240]}
//                                               a UniK3D camera (its classes: unik3d.h); optional
//                                               "width" and "height", else the caller's size
// What we write parses back exactly: to_spec(), cameras_txt_line(), to_cameras_txt(), to_json().
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "omnipoint/camera/camera_model.h"

namespace omnipoint::camera {

class Camera {
 public:
  // Throws std::invalid_argument naming the model and what it expects when the size or the
  // parameters are wrong (count, non-finite, the model's own rules).
  Camera(const std::string& model, int64_t width, int64_t height, std::vector<double> params);

  const std::string& model_name() const { return model_name_; }
  const CameraModel& model() const { return *model_; }
  int64_t width() const { return width_; }
  int64_t height() const { return height_; }
  ImageSize size() const { return {width_, height_}; }
  const std::vector<double>& params() const { return params_; }
  // The parameters as a 1-D tensor.
  at::Tensor params_tensor(at::TensorOptions options = at::kDouble) const;

  // Pixels (..., 2) -> unit rays (..., 3); dtype/device follow the input.
  Rays unproject(const at::Tensor& pixels) const;
  // Points (..., 3) -> pixels (..., 2); dtype/device follow the input. Valid means inside the
  // model's domain; use `inside_image` for the image bounds.
  Pixels project(const at::Tensor& points) const;
  // Whether pixels (..., 2) lie inside [0, width] x [0, height].
  at::Tensor inside_image(const at::Tensor& pixels) const;
  // Pixel centres (H, W, 2) = (i + 0.5, j + 0.5).
  at::Tensor pixel_centres(at::TensorOptions options = at::kFloat) const;
  // Rays (H, W, 3) and valid (H, W) at pixel centres.
  Rays ray_map(at::TensorOptions options = at::kFloat) const;

  // The camera of the image resized to new_width x new_height.
  Camera resized(int64_t new_width, int64_t new_height) const;
  // The camera of the window [x0, x0 + width) x [y0, y0 + height) of the image (the window
  // may extend beyond the image: the model is defined there too).
  Camera cropped(int64_t x0, int64_t y0, int64_t width, int64_t height) const;

  // COLMAP line "MODEL W H p1 p2 ...", with full double precision (parses back exactly).
  std::string to_spec() const;
  // {"model": .., "width": .., "height": .., "params": [..]}
  std::string to_json() const;

  bool operator==(const Camera& other) const;
  bool operator!=(const Camera& other) const { return !(*this == other); }

 private:
  const CameraModel* model_;
  std::string model_name_;
  int64_t width_;
  int64_t height_;
  std::vector<double> params_;
};

Camera make_camera(const std::string& model, int64_t width, int64_t height,
                   std::vector<double> params);
// Parses a spec string (the forms above). Bad specs -> std::invalid_argument naming the spec
// and what was expected. `image_size` is the size of a camera whose spec has none (UniK3D's
// JSON); it is unused otherwise.
Camera parse_camera(const std::string& spec, std::optional<ImageSize> image_size = std::nullopt);
// Whether `spec` has the shape of a spec string (rather than, say, a file name).
bool is_camera_line(const std::string& spec);
// Parses the contents of a camera file: a cameras.txt ('#' comments, "ID MODEL W H PARAMS..."
// lines; `id` picks one, empty = the first) or one JSON object (the forms above). `source`
// names the file in errors (std::invalid_argument); `image_size` as for parse_camera.
Camera parse_camera_file(const std::string& text, const std::string& source,
                         const std::string& id = "",
                         std::optional<ImageSize> image_size = std::nullopt);
// The cameras.txt line "ID MODEL W H PARAMS..." (full precision, as to_spec()).
std::string cameras_txt_line(const Camera& camera, int64_t id = 1);
// A COLMAP cameras.txt holding `camera`: COLMAP's header comments, then its line.
std::string to_cameras_txt(const Camera& camera, int64_t id = 1);
// PINHOLE camera with the given horizontal field of view (0 < fov < 180 degrees), square
// pixels and the principal point at the image centre (the short form `--fov 90`).
Camera centred_pinhole(double horizontal_fov_deg, int64_t width, int64_t height);

}  // namespace omnipoint::camera
