#pragma once
// OmniPoint's main API: one image (+ optional camera, + optional sparse depth) -> a metric
// point cloud. Load a model once, then call predict from any number of threads:
//
//   const omnipoint::Model model = omnipoint::Model::load("model.safetensors", at::kCPU);
//   omnipoint::PredictOptions options;
//   options.camera = omnipoint::camera::parse_camera("PINHOLE 640 480 500 500 320 240");
//   const omnipoint::Prediction p = model.predict(image, options);  // image (H, W, 3) RGB [0, 1]
//   // p.points (H, W, 3) metres where p.mask, p.fitted_camera, p.timing ...
//
// Conventions (docs/DESIGN.md): camera frame x right, y down, z forward, metres; P = s·d·r with r
// the unit ray of a pixel, d its radial distance (metric here: the scale s is applied) and
// planar depth z = P.z (negative behind wide lenses). Outputs are float32 CPU tensors.
//
// Models: OmniPoint checkpoints (metadata "format": "omnipoint") take the camera as their ray
// condition and the sparse depth as their depth condition; MoGe-2 checkpoints ("moge2") run as
// pinhole models — their points give rays and distances, the camera is not an input to them and
// the sparse depth only serves the metric alignment; on a wide camera (camera::camera_class:
// fisheye, unified, FOV models, panoramas) they run in A2P's multi-view mode (augment/a2p.h).
// Prediction::notes says which. These rules live in infer::run (omnipoint/infer/infer.h), the
// inference path `omnipoint eval` scores too; predict adds the inputs' conversion, the camera
// fit and the CPU outputs.
#include <ATen/core/Tensor.h>
#include <c10/core/Device.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/fit.h"
#include "omnipoint/model/precision.h"

namespace omnipoint::infer {
class Network;
}

namespace omnipoint::predict {

// sparse_depth_warnings' advice for a point cloud that misses the image, on the command line.
inline constexpr const char* kLidarToCameraAdvice =
    "pass --lidar-to-camera, or check the transform's direction";

// Metric sparse depth for one image; zero or non-finite values are missing samples.
struct SparseDepthInput {
  // A depth map (H, W) at the image's size, in metres: planar depth z (depth images, the
  // usual convention) or, with depth_is_planar = false, radial distance along the rays.
  at::Tensor depth_map;
  bool depth_is_planar = true;
  // Or a point cloud (N, 3) in metres (e.g. a LiDAR scan), projected through the camera with
  // the rule for a sensor's sweep (sparse_distance_map); camera_from_lidar (4, 4) maps it into
  // the camera frame (identity if undefined).
  at::Tensor lidar_points;
  at::Tensor camera_from_lidar;
  // What places the point cloud in the camera frame, as the warning about a cloud that misses
  // the image advises checking it (predict's --lidar-to-camera; a rig's poses).
  std::string placement_advice = kLidarToCameraAdvice;

  bool empty() const { return !depth_map.defined() && !lidar_points.defined(); }
};

// MoGe's tolerance for removing depth edges (moge/scripts/infer.py `--threshold`: its default
// is 0.04, although its help text says 0.01).
inline constexpr double kDefaultEdgeRtol = 0.04;

// Where a prediction's camera comes from (camera.json's "camera_source").
enum class CameraSource {
  kNone,    // no camera: none given and none fitted
  kGiven,   // the user's (a camera spec or file, a field of view, a COLMAP reconstruction)
  kExif,    // the photo's EXIF focal length (predict/inputs.h: camera_from_exif)
  kFitted,  // fitted to the predicted rays (PredictOptions::fit_model)
};
// "none", "given", "exif", "fitted".
const char* camera_source_name(CameraSource source);

struct PredictOptions {
  // The image's camera (any model); its size must equal the image's or have its aspect ratio
  // (it is then resized). It conditions the network, and the output points lie on its rays
  // (invalid outside its domain). Without it the model predicts the rays.
  std::optional<camera::Camera> camera;
  // Where `camera` comes from: kGiven or kExif (recorded in Prediction::camera_source).
  CameraSource camera_source = CameraSource::kGiven;
  SparseDepthInput sparse_depth;
  int64_t num_tokens = 0;  // ViT token budget; 0: the model's default (infer::Network)
  // The camera reported (Prediction::fitted_camera). "auto": the given camera as it is, else
  // the model camera::fit_camera_auto chooses by residual (camera/fit.h: the rule); a model
  // name ("PINHOLE", "OPENCV_FISHEYE", ...): that model fitted to the output rays (a given
  // camera of that model is reported as it is); "": no fit (a given camera is still reported).
  std::string fit_model = "auto";
  // Rescale the metric scale to the sparse depth (robust L1 fit, paper) when there is any.
  bool align_to_sparse_depth = true;
  // Flying-pixel removal (remove_depth_edges): pixels at a depth discontinuity of more than
  // this relative tolerance leave the mask; 0: off.
  double edge_rtol = kDefaultEdgeRtol;
  // false: the sparse depth is in arbitrary units (a COLMAP reconstruction's), so the prediction
  // takes its scale and a far-from-1 alignment factor is expected, not a warning.
  bool sparse_depth_is_metric = true;
  // The network's precision (model/precision.h: bf16 on CPU or CUDA, fp16 on CUDA); the
  // geometry after the network is fp32 whatever it is.
  model::Precision precision = model::Precision::kFloat32;
};

// Wall-clock milliseconds per stage of one predict call.
struct StageTimes {
  double prepare_ms = 0;     // image, ray-map and sparse-depth tensors
  double network_ms = 0;     // forward pass(es) and the model's own post-processing
  double alignment_ms = 0;   // metric alignment to the sparse depth
  double camera_fit_ms = 0;  // fit_camera on the predicted rays
  double total_ms() const { return prepare_ms + network_ms + alignment_ms + camera_fit_ms; }
};

struct Prediction {
  at::Tensor rays;                  // (H, W, 3) unit rays; zero where invalid
  at::Tensor distance;              // (H, W) metric radial distance; zero where mask is false
  at::Tensor depth;                 // (H, W) planar depth z = P.z; zero where mask is false
  at::Tensor points;                // (H, W, 3) metric points; zero where mask is false
  at::Tensor mask;                  // (H, W) bool: valid geometry
  double metric_scale = 1.0;        // s (after alignment); 1 for scale-less (affine) models
  double alignment_factor = 1.0;    // the factor the sparse-depth alignment applied to s
  int64_t sparse_samples = 0;       // valid sparse-depth pixels used
  double edge_rtol = 0;             // the flying-pixel filter's tolerance (0: not applied)
  int64_t edge_pixels_removed = 0;  // pixels it took out of the mask
  // The image's camera: the given one at the image's size (the rays are its rays), else the
  // one fitted to the rays (PredictOptions::fit_model).
  std::optional<camera::Camera> fitted_camera;
  // Set exactly when fitted_camera was fitted: the angle between its rays and `rays` over the
  // pixels valid before the flying-pixel filter (camera::angular_residual; the fit uses them
  // too: their rays are as good as any). A given camera has none: its rays are `rays`.
  std::optional<camera::AngularResidual> fit_residual;
  CameraSource camera_source = CameraSource::kNone;  // fitted_camera's
  // With a given (or EXIF) camera and a network that predicts rays of its own (OmniPoint, and
  // MoGe-2 on a pinhole): the angle between the camera's rays and the network's over the pixels
  // valid before the flying-pixel filter (camera::angular_residual). Large: the camera and the
  // picture disagree (a wrong focal length, a cropped or resized photo).
  std::optional<camera::AngularResidual> camera_agreement;
  std::string fit_error;  // why no camera was fitted, when fit_model asked for one
  model::Precision precision = model::Precision::kFloat32;  // the network's
  std::vector<std::string> notes;     // what the prediction did that a user should know
  std::vector<std::string> warnings;  // inputs that look wrong (sparse_depth_warnings)
  StageTimes timing;
};

// Where p.fitted_camera comes from: p.camera_source, or for a prediction assembled by hand
// (prediction_from_geometry) that names none, kFitted when it has a fit residual, else kGiven.
CameraSource camera_source_of(const Prediction& p);

// A loaded model. Copies share the weights; predict is const and thread-safe (inference mode,
// no shared mutable state).
class Model {
 public:
  // Reads a .safetensors checkpoint, dispatching on its metadata "format" ("omnipoint" or
  // "moge2"), onto `device`. std::runtime_error for unreadable files, std::invalid_argument
  // for files that are not a model we know; both name the path.
  static Model load(const std::string& path, at::Device device = at::kCPU);

  // image: (H, W, 3) RGB in [0, 1] (float, or uint8 in [0, 255]), any device.
  Prediction predict(const at::Tensor& image, const PredictOptions& options = {}) const;
  // A batch of images of one size (B, H, W, 3) with shared options, in one forward pass; the
  // sparse depth (if any) must be a depth map (B, H, W). Each result's timing is the batch's.
  std::vector<Prediction> predict_batch(const at::Tensor& images,
                                        const PredictOptions& options = {}) const;

  const std::string& format() const;  // "omnipoint" or "moge2"
  at::Device device() const;
  int64_t default_num_tokens() const;
  const infer::Network& network() const;  // the loaded network (omnipoint/infer/infer.h)

  struct Impl;

 private:
  explicit Model(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  std::shared_ptr<const Impl> impl_;
};

// The sparse input as a (H, W) metric radial-distance map of the image: depth maps checked
// against the size and converted along `rays` (H, W, 3) when planar; point clouds projected
// through `camera` (required for them) as a sensor's sweep: returns hidden from the camera behind
// nearer ones dropped, each pixel's sample the return nearest to its centre
// (geometry::PointSelection::kSensorSweep). Zero where there is no sample.
at::Tensor sparse_distance_map(const SparseDepthInput& input, int64_t width, int64_t height,
                               const at::Tensor& rays, const camera::Camera* camera);

// What looks wrong about a sparse depth input, given how many samples it had in the image
// (`in_image`: pixels of its distance map; for a point cloud out of `cloud_points` points) and
// how many the prediction used with what alignment factor: no usable sample (nothing aligned),
// a point cloud of which almost nothing lands in the image (< 0.5 % of its points, or < 20: the
// wrong frame or transform), and metric sparse depth whose scale disagrees with the network's
// by more than 3x (wrong units such as a KITTI PNG read as millimetres, or a wrong transform).
// `placement_advice` is what the warning about a cloud that misses the image advises
// (SparseDepthInput::placement_advice).
std::vector<std::string> sparse_depth_warnings(
    int64_t in_image, int64_t cloud_points, int64_t used, double alignment_factor,
    bool sparse_depth_is_metric, const std::string& placement_advice = kLidarToCameraAdvice);

// Removes the flying pixels at depth edges (geometry::depth_edge_mask on the radial distance,
// so wide lenses and panoramas too) from p.mask and zeroes their points, distance and depth
// (the rays stay: they are the camera's); records rtol and the count in p. rtol <= 0: no-op.
void remove_depth_edges(Prediction& p, double rtol);

// Brings p to another metric scale: its distances, points and depth times
// metric_scale / p.metric_scale; p.metric_scale becomes metric_scale (a positive number).
void apply_metric_scale(Prediction& p, double metric_scale);

// A prediction built from geometry alone (the output writers' input; also the oracle path of
// the tests): rays (H, W, 3), metric distance (H, W), mask (H, W); points, depth and the
// zeroing outside the mask follow.
Prediction prediction_from_geometry(const at::Tensor& rays, const at::Tensor& distance,
                                    const at::Tensor& mask, double metric_scale = 1.0);

}  // namespace omnipoint::predict

namespace omnipoint {
using predict::Model;
using predict::Prediction;
using predict::PredictOptions;
using predict::SparseDepthInput;
}  // namespace omnipoint
