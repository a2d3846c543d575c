#pragma once
// The interface every camera model implements (after COLMAP's sensor/models.h).
//
// Conventions (docs/DESIGN.md; they hold for every model):
// - Camera frame: x right, y down, z forward.
// - Pixels: (x, y) = (column, row) in pixel units; the top-left image corner is (0, 0) and
//   the centre of pixel (col i, row j) is (i + 0.5, j + 0.5). OpenCV's cx, cy are ours - 0.5.
// - Parameters: COLMAP's names and order (`param_names()`), e.g. OPENCV = fx fy cx cy k1 k2
//   p1 p2. Focal lengths and principal points are in pixels; distortion acts on normalised
//   coordinates, so it does not change when the image is resized. The formulas name the
//   parameters as `param_names()` does (`const auto k1 = params[4];`, COLMAP's style); the
//   intrinsics come by name from `focal_principal`.
// - Batching: `project`/`unproject` take any leading shape (..., 3) / (..., 2), run on the
//   dtype and device of their input (`params` is a 1-D tensor with that dtype and device),
//   and never produce NaN: where a model is undefined the result is zero and valid = false.
//
// How to add a model:
// 1. Write `<name>.cpp` with a class deriving from CameraModel (or DistortedPinholeModel in
//    distorted_pinhole.h when the model is "pinhole + distortion of normalised coordinates",
//    which then only needs `distort`). Give it closed forms where they exist; otherwise
//    invert with `solve_2d` (solve.h). Override `check_params` for the model's rules (with
//    `check_focal_positive` and `require_param`, which word the errors alike), and
//    `scaled_params`/`cropped_params`/`initial_params` only when the parameter layout is not
//    "f|fx fy, cx cy, then dimensionless parameters".
// 2. End the file with an accessor `const CameraModel& <name>_model()` returning a static
//    instance, declare it and add it to the table in registry.cpp (one line each).
// 3. Add a sample camera to tests/camera/sample_cameras.h: the typed tests then cover it.
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>
#include <vector>

namespace omnipoint::camera {

// Unit rays (..., 3), zero where invalid; valid (...) bool.
struct Rays {
  at::Tensor rays;
  at::Tensor valid;
};

// Pixel coordinates (..., 2) = (x, y), zero where invalid; valid (...) bool. Validity means
// "inside the model's domain", not "inside the image".
struct Pixels {
  at::Tensor pixels;
  at::Tensor valid;
};

struct ImageSize {
  int64_t width = 0;
  int64_t height = 0;
};

class CameraModel {
 public:
  virtual ~CameraModel() = default;

  // COLMAP-style name, e.g. "OPENCV".
  virtual std::string name() const = 0;
  // Parameter names in COLMAP order.
  virtual std::vector<std::string> param_names() const = 0;
  // Whether `count` parameters form a valid parameter vector (default: exactly
  // param_names().size(); EQUIRECTANGULAR also accepts none).
  virtual bool accepts_param_count(std::size_t count) const;
  // What the model expects, for error messages, e.g. "8 parameters (fx fy cx cy k1 k2 p1 p2)".
  virtual std::string expected_params() const;
  // The model's rules on values (count and finiteness are checked before by the framework).
  // Throws std::invalid_argument naming the model and what it expects.
  virtual void check_params(const std::vector<double>& params, ImageSize size) const;

  // 3-D points (..., 3) in the camera frame -> pixels. Points need not be unit length.
  virtual Pixels project(const at::Tensor& params, ImageSize size,
                         const at::Tensor& points) const = 0;
  // Pixels (..., 2) -> unit rays.
  virtual Rays unproject(const at::Tensor& params, ImageSize size,
                         const at::Tensor& pixels) const = 0;

  // Parameters after resizing the image by (sx, sy) = (new width / width, new height /
  // height). Default: focal lengths and principal point scale (a single focal `f` by the
  // mean of sx and sy, exact for uniform resizes), all other parameters are unchanged.
  virtual std::vector<double> scaled_params(const std::vector<double>& params, double sx,
                                            double sy) const;
  // Parameters after cropping the window [x0, x0 + new_size.width) x [y0, y0 +
  // new_size.height) out of an image of `size`. Default: the principal point moves.
  virtual std::vector<double> cropped_params(const std::vector<double>& params, ImageSize size,
                                             double x0, double y0, ImageSize new_size) const;
  // Starting parameters for fitting (fit.h) from a pinhole approximation near the axis.
  // Default: f|fx|fy|cx|cy by name, every other parameter 0 (no distortion).
  virtual std::vector<double> initial_params(double fx, double fy, double cx, double cy,
                                             ImageSize size) const;
};

// The registry of all models (registry.cpp).
// Throws std::invalid_argument listing the known models when `name` is unknown.
const CameraModel& find_camera_model(const std::string& name);
std::vector<std::string> camera_model_names();

// Helpers for the common "f cx cy ..." / "fx fy cx cy ..." layout: the intrinsics as scalar
// tensors (0-d, the dtype/device of `params`) that broadcast against a batch.
struct FocalPrincipal {
  at::Tensor fx, fy, cx, cy;
};
FocalPrincipal focal_principal(const CameraModel& model, const at::Tensor& params);
// Pixels -> normalised coordinates ((x - cx) / fx, (y - cy) / fy), and back.
at::Tensor normalise_pixels(const FocalPrincipal& k, const at::Tensor& pixels);
at::Tensor denormalise_pixels(const FocalPrincipal& k, const at::Tensor& normalised);
// (x, y) on the plane z = 1 -> unit rays.
at::Tensor rays_from_plane(const at::Tensor& normalised);
// Reductions over the short last dimension (2 or 3) of coordinate tensors, written
// element-wise: ATen's reductions over a tiny last dimension are several times slower.
at::Tensor squared_length(const at::Tensor& v);  // (...): sum of squares
at::Tensor length(const at::Tensor& v);          // (...): Euclidean length
at::Tensor all_finite(const at::Tensor& v);      // (...) bool
// Throws std::invalid_argument "<MODEL>: <name> must be <expected>, got <value>" unless ok.
void require_param(const CameraModel& model, const std::string& name, double value, bool ok,
                   const std::string& expected);
// Throws std::invalid_argument unless the focal lengths are > 0.
void check_focal_positive(const CameraModel& model, const std::vector<double>& params);

}  // namespace omnipoint::camera
