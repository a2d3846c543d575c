#pragma once
// The one inference path (docs/DESIGN.md): a network loaded from a checkpoint of either format, run
// on a batch of images with whatever camera and sparse depth are known. predict::Model, the
// eval predictors, the A2P teachers and `omnipoint forward` all call it, so what eval scores
// is what predict ships.
//
//   const infer::Network network = infer::load_network("model.safetensors", at::kCPU);
//   infer::Inputs inputs;
//   inputs.images = images;  // (B, 3, H, W) RGB in [0, 1]
//   inputs.camera = camera;  // optional, at the images' size
//   const infer::Result result = infer::run(network, inputs);
//
// The rules, once:
// - Tokens: 0 asks for the model's default (OmniPoint: the top of its num_tokens_range;
//   MoGe-2: its infer() default, the top resolution level).
// - A given camera is used as it is: its rays carry the predicted distances, and pixels outside
//   its domain are invalid; the predicted rays stand in only for an unknown camera.
// - OmniPoint takes the camera and the sparse depth as conditions. MoGe-2 runs as a pinhole
//   model: the camera is no input to it, and on a wide camera (camera::camera_class not
//   kPerspective) it runs in A2P's multi-view mode (pinhole views tiling the field of view,
//   merged scale-consistently; augment/a2p.h).
// - Sparse depth aligns the metric scale (geometry::fit_scale_to_sparse_depth over the samples
//   where the prediction is valid) for both formats when align_to_sparse_depth.
#include <ATen/core/Tensor.h>
#include <c10/core/Device.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/omnipoint_model.h"
#include "omnipoint/model/precision.h"

namespace omnipoint::infer {

// A network of either checkpoint format, in eval mode on its device. Copies share the weights;
// running it mutates nothing (inference mode), so one network serves concurrent runs.
class Network {
 public:
  explicit Network(model::OmniPointModel model, at::Device device = at::kCPU);
  explicit Network(model::MoGe2Model model, at::Device device = at::kCPU);

  const std::string& format() const { return format_; }  // "omnipoint" or "moge2"
  at::Device device() const { return device_; }
  int64_t default_num_tokens() const { return default_num_tokens_; }
  int64_t num_tokens(int64_t requested) const {  // requested > 0, else the default
    return requested > 0 ? requested : default_num_tokens_;
  }
  // The module of the format (the other is null); holders share the module.
  model::OmniPointModel omnipoint() const { return omnipoint_; }
  model::MoGe2Model moge2() const { return moge2_; }

 private:
  std::string format_;
  at::Device device_;
  int64_t default_num_tokens_ = 0;
  model::OmniPointModel omnipoint_{nullptr};
  model::MoGe2Model moge2_{nullptr};
};

// The one checkpoint loader: reads a .safetensors file or a PyTorch checkpoint (MoGe's
// model.pt; io/torch_checkpoint.h) and dispatches once on its metadata "format": "omnipoint",
// or "moge2" (also when absent: converted MoGe-2 checkpoints carry only their config). Errors name the path: std::runtime_error for an unreadable file,
// std::invalid_argument for one that is not a model we know.
Network load_network(const std::string& path, at::Device device = at::kCPU);

struct Inputs {
  at::Tensor images;                     // (B, 3, H, W) RGB in [0, 1], any device
  std::optional<camera::Camera> camera;  // the images' camera, at their size
  at::Tensor sparse_distance;            // (B, H, W) metric radial distances; 0: no sample
  int64_t num_tokens = 0;                // ViT token budget; 0: the model's default
  bool align_to_sparse_depth = true;
  // The network's precision (model/precision.h); the geometry after it is fp32 whatever it is.
  model::Precision precision = model::Precision::kFloat32;
};

// Milliseconds of one run.
struct Timings {
  double network_ms = 0;    // forward pass(es) and the model's own post-processing
  double alignment_ms = 0;  // the metric alignment to the sparse depth
};

// The geometry a prediction ships (predict::Prediction, and so what eval scores), any leading
// dimensions: a pixel is valid where the mask holds, the distance is finite and positive and
// the ray is a unit ray; distance and points are zero elsewhere, non-finite rays zero.
struct PointMap {
  at::Tensor rays;      // (..., 3)
  at::Tensor distance;  // (...) metric radial distance
  at::Tensor points;    // (..., 3) distance · rays
  at::Tensor mask;      // (...) bool
};
PointMap point_map(const at::Tensor& rays, const at::Tensor& distance, const at::Tensor& mask);

// On the network's device, in the layout of the rays (B, H, W, ...).
struct Result {
  at::Tensor rays;  // (B, H, W, 3) unit rays (the given camera's, else predicted)
  // With a given camera, the rays the network predicted of its own (undefined in MoGe-2's
  // multi-view mode, which predicts none for the whole image; and without a camera: `rays`).
  at::Tensor predicted_rays;
  at::Tensor distance;      // (B, H, W) scale-invariant: metric_scale · distance is metric
  at::Tensor mask;          // (B, H, W) bool: the network's mask (and the camera's domain)
  at::Tensor metric_scale;  // (B) after the alignment; 1 without a scale head
  // What predict ships and eval scores: metric_scale · distance along the rays, under the
  // mask (point_map), computed once here.
  PointMap shipped;
  bool metric = false;      // whether the shipped points are metres (a scale head, or aligned)
  bool multi_view = false;  // MoGe-2 on a wide camera
  // The sparse-depth alignment: the factor applied to the network's metric scale (1 where
  // not aligned) and the samples it used (sparse samples where the mask holds).
  at::Tensor alignment_factor;  // (B)
  at::Tensor sparse_samples;    // (B) int64
  bool aligned = false;
  std::vector<std::string> notes;  // what the run did that a user should know
  Timings timing;
};

Result run(const Network& network, const Inputs& inputs);

// The raw outputs of one forward pass without conditions (`omnipoint forward`): points
// (B, H, W, 3) (OmniPoint: metric; MoGe-2: its affine point map), mask (B, H, W) probability,
// metric_scale (B), rays and distance (P = distance · rays; MoGe-2: factored from its points),
// normal (B, H, W, 3) where the model has one. Undefined where the model lacks a head.
struct RawOutput {
  at::Tensor points, mask, metric_scale, rays, distance, normal;
};
RawOutput forward(const Network& network, const at::Tensor& images, int64_t num_tokens = 0,
                  model::Precision precision = model::Precision::kFloat32);

}  // namespace omnipoint::infer
