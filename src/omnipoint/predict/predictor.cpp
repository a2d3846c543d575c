// Model::load / predict: the network behind one call, with its conditions prepared from the
// user's camera and sparse depth, the metric alignment and the camera fit after it.
#include "omnipoint/predict/predictor.h"

#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>

#include <chrono>
#include <cmath>
#include <stdexcept>
#include <utility>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/camera/fit.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/infer/teacher.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/conditioning.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/moge2_infer.h"
#include "omnipoint/model/omnipoint_model.h"
#include "omnipoint/model/omnipoint_weights.h"

namespace omnipoint::predict {

struct Model::Impl {
  std::string format;
  at::Device device = at::kCPU;
  int64_t default_num_tokens = 0;
  // Modules are not const-callable; forward passes in inference mode mutate nothing, which is
  // what makes concurrent predict calls safe.
  mutable model::OmniPointModel omnipoint{nullptr};
  mutable model::MoGe2Model moge2{nullptr};
};

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Raw network geometry of a batch: (B,H,W,3) rays, (B,H,W) scale-invariant distance,
// (B,H,W) bool mask, (B) metric scale.
struct NetworkGeometry {
  at::Tensor rays, distance, mask, metric_scale;
};

// (B,H,W,3) images -> (B,3,H,W) float32 in [0,1] on the device.
at::Tensor network_input(const at::Tensor& images, at::Device device) {
  if (images.dim() != 4 || images.size(3) != 3 || images.size(1) < 1 || images.size(2) < 1)
    throw std::invalid_argument("predict: expected images (H, W, 3) or (B, H, W, 3) RGB, got " +
                                c10::str(images.sizes()));
  at::Tensor input =
      images.scalar_type() == at::kByte ? images.to(at::kFloat) / 255.0 : images.to(at::kFloat);
  if (!at::isfinite(input).all().item<bool>() || input.min().item<float>() < 0 ||
      input.max().item<float>() > 1)
    throw std::invalid_argument("predict: image values must be finite RGB in [0, 1]");
  return input.permute({0, 3, 1, 2}).contiguous().to(device);
}

camera::Camera camera_for_image(const camera::Camera& camera, int64_t width, int64_t height) {
  if (camera.width() == width && camera.height() == height) return camera;
  const double aspect = static_cast<double>(camera.width()) / camera.height();
  const double image_aspect = static_cast<double>(width) / height;
  if (std::abs(aspect / image_aspect - 1.0) > 0.01)
    throw std::invalid_argument("predict: the camera is " + std::to_string(camera.width()) + "x" +
                                std::to_string(camera.height()) + " but the image is " +
                                std::to_string(width) + "x" + std::to_string(height) +
                                " (a different aspect ratio)");
  return camera.resized(width, height);
}

NetworkGeometry run_network(const Model::Impl& impl, const at::Tensor& input,
                            const at::Tensor& rays, const at::Tensor& sparse_distance,
                            int64_t num_tokens) {
  if (impl.omnipoint) {
    model::OmniPointInputs inputs;
    inputs.image = input;
    if (rays.defined()) inputs.rays = rays.permute({0, 3, 1, 2}).contiguous();
    inputs.sparse_depth = sparse_distance;
    const model::OmniPointOutput out = impl.omnipoint->forward(inputs, num_tokens);
    return {out.rays, out.distance, out.mask > 0.5, out.metric_scale};
  }
  model::MoGe2InferOptions options;
  options.apply_mask = false;
  const model::MoGe2Inference out = model::infer(impl.moge2, input, num_tokens, options);
  const at::Tensor scale =
      out.metric_scale.defined() ? out.metric_scale : at::ones({input.size(0)}, input.options());
  // infer's points are already metric: divide the scale back out of the distances.
  return {out.rays, out.distance / scale.view({-1, 1, 1}), out.mask, scale};
}

// A perspective-only model (MoGe-2) on a wide camera: A2P's multi-view mode — pinhole views
// tiling the camera's field of view, each predicted and merged scale-consistently.
NetworkGeometry run_multi_view(const Model::Impl& impl, const at::Tensor& input,
                               const camera::Camera& camera, const at::Tensor& camera_rays,
                               int64_t num_tokens) {
  const augment::Teacher teacher = infer::moge2_teacher(impl.moge2, num_tokens);
  std::vector<at::Tensor> distances, masks;
  for (int64_t b = 0; b < input.size(0); ++b) {
    const augment::MergedPrediction merged =
        augment::predict_wide_from_views(camera, input[b].permute({1, 2, 0}), teacher);
    distances.push_back(merged.distance.to(input.options()));
    masks.push_back(merged.mask.to(input.device()));
  }
  const at::Tensor distance = at::stack(distances), mask = at::stack(masks) & (distance > 0);
  return {camera_rays, distance, mask, at::ones({input.size(0)}, input.options())};
}

std::optional<camera::Camera> fit(const std::string& requested,
                                  const std::optional<camera::Camera>& given,
                                  const at::Tensor& rays, const at::Tensor& mask,
                                  std::string* error) {
  if (requested.empty()) return std::nullopt;
  const at::Tensor valid = mask & (rays.norm(2, -1) > 0.5);
  const std::string name = requested != "auto" ? requested
                           : given             ? given->model_name()
                                               : auto_fit_model(rays, valid);
  try {
    return camera::fit_camera(name, rays.size(1), rays.size(0), rays, valid);
  } catch (const std::invalid_argument& e) {
    *error = e.what();
    return std::nullopt;
  }
}

}  // namespace

Model Model::load(const std::string& path, at::Device device) {
  const io::SafetensorsFile file = io::read_safetensors(path);
  auto impl = std::make_shared<Impl>();
  impl->device = device;
  const auto format = file.metadata.find("format");
  impl->format = format == file.metadata.end() ? "moge2" : format->second;
  try {
    if (impl->format == "omnipoint") {
      impl->omnipoint = model::load_omnipoint_model(file.tensors, file.metadata);
      impl->omnipoint->eval();
      impl->omnipoint->to(device);
      impl->default_num_tokens = impl->omnipoint->config().num_tokens_range[1];
    } else if (impl->format == "moge2") {
      impl->moge2 = model::load_moge2(file.tensors, file.metadata);
      impl->moge2->eval();
      impl->moge2->to(device);
      impl->default_num_tokens = impl->moge2->config().default_num_tokens();
    } else {
      throw std::invalid_argument("unknown metadata format \"" + impl->format +
                                  "\" (expected \"omnipoint\" or \"moge2\")");
    }
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("model " + path + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw std::runtime_error("model " + path + ": " + e.what());
  }
  return Model(std::move(impl));
}

const std::string& Model::format() const {
  return impl_->format;
}
at::Device Model::device() const {
  return impl_->device;
}
int64_t Model::default_num_tokens() const {
  return impl_->default_num_tokens;
}

Prediction Model::predict(const at::Tensor& image, const PredictOptions& options) const {
  if (image.dim() != 3)
    throw std::invalid_argument("predict: expected an image (H, W, 3), got " +
                                c10::str(image.sizes()));
  PredictOptions batch_options = options;
  if (options.sparse_depth.depth_map.defined()) {
    if (options.sparse_depth.depth_map.dim() != 2)
      throw std::invalid_argument("predict: the sparse depth map must be (H, W), got " +
                                  c10::str(options.sparse_depth.depth_map.sizes()));
    batch_options.sparse_depth.depth_map = options.sparse_depth.depth_map.unsqueeze(0);
  }
  return std::move(predict_batch(image.unsqueeze(0), batch_options).front());
}

std::vector<Prediction> Model::predict_batch(const at::Tensor& images,
                                             const PredictOptions& options) const {
  c10::InferenceMode inference;
  StageTimes timing;
  std::vector<std::string> notes;
  auto start = Clock::now();
  const at::Tensor input = network_input(images, impl_->device);
  const int64_t batch = input.size(0), height = input.size(2), width = input.size(3);
  const int64_t num_tokens =
      options.num_tokens > 0 ? options.num_tokens : impl_->default_num_tokens;
  const SparseDepthInput& sparse = options.sparse_depth;
  if (sparse.lidar_points.defined() && batch != 1)
    throw std::invalid_argument("predict: a point-cloud sparse depth needs a batch of one image");
  if (sparse.depth_map.defined() &&
      (sparse.depth_map.dim() != 3 || sparse.depth_map.size(0) != batch))
    throw std::invalid_argument(
        "predict: the sparse depth maps must be (B, H, W) with B = " + std::to_string(batch) +
        ", got " + c10::str(sparse.depth_map.sizes()));

  std::optional<camera::Camera> camera;
  at::Tensor camera_rays;   // (B,H,W,3) on the device
  at::Tensor camera_valid;  // (H,W) where the camera has rays
  bool multi_view = false;  // a perspective-only model on a wide camera
  if (options.camera) {
    camera = camera_for_image(*options.camera, width, height);
    const camera::Rays ray_map = camera->ray_map(input.options());
    camera_rays = ray_map.rays.unsqueeze(0).expand({batch, height, width, 3});
    camera_valid = ray_map.valid;
    if (impl_->moge2) {
      multi_view =
          auto_fit_model(ray_map.rays.to(at::kCPU), ray_map.valid.to(at::kCPU)) != "PINHOLE";
      notes.push_back(
          multi_view
              ? "MoGe-2 checkpoint on a wide camera: multi-view mode (pinhole views tiling the "
                "field of view, predicted and merged)"
              : "MoGe-2 checkpoint: the camera is not a network input (pinhole model)");
    }
  }
  timing.prepare_ms += ms_since(start);

  // The sparse depth as radial distances needs rays (planar maps) or a camera (point clouds);
  // without a given camera they come from a first pass without sparse depth.
  at::Tensor sparse_distance;  // (B,H,W)
  if (!sparse.empty()) {
    at::Tensor rays = camera_rays;
    std::optional<camera::Camera> projection = camera;
    const bool needs_rays = sparse.depth_map.defined() && sparse.depth_is_planar;
    if (!camera && (needs_rays || sparse.lidar_points.defined())) {
      start = Clock::now();
      const NetworkGeometry first = run_network(*impl_, input, {}, {}, num_tokens);
      timing.network_ms += ms_since(start);
      rays = first.rays;
      if (sparse.lidar_points.defined()) {
        start = Clock::now();
        std::string error;
        projection = fit("auto", std::nullopt, first.rays[0].to(at::kCPU),
                         first.mask[0].to(at::kCPU), &error);
        timing.camera_fit_ms += ms_since(start);
        if (!projection)
          throw std::invalid_argument(
              "predict: no camera to project the point cloud through (none given, and the "
              "predicted rays fit none: " +
              error + "); pass the camera");
      }
      notes.push_back(
          "sparse depth converted with the predicted camera (none given); a first pass without it "
          "ran");
    }
    start = Clock::now();
    std::vector<at::Tensor> maps;
    for (int64_t b = 0; b < batch; ++b) {
      SparseDepthInput item = sparse;
      if (item.depth_map.defined()) item.depth_map = sparse.depth_map[b];
      maps.push_back(sparse_distance_map(item, width, height,
                                         rays.defined() ? rays[b] : at::Tensor(),
                                         projection ? &*projection : nullptr)
                         .to(input.options()));
    }
    sparse_distance = at::stack(maps);
    if (impl_->moge2)
      notes.push_back("MoGe-2 checkpoint: the sparse depth only aligns the metric scale");
    timing.prepare_ms += ms_since(start);
  }

  start = Clock::now();
  const NetworkGeometry net =
      multi_view ? run_multi_view(*impl_, input, *camera, camera_rays, num_tokens)
                 : run_network(*impl_, input, camera_rays,
                               impl_->omnipoint ? sparse_distance : at::Tensor(), num_tokens);
  at::Tensor scale = net.metric_scale;
  timing.network_ms += ms_since(start);

  start = Clock::now();
  at::Tensor factor = at::ones_like(scale);
  at::Tensor samples = at::zeros({batch}, scale.options().dtype(at::kLong));
  if (sparse_distance.defined()) {
    const at::Tensor usable = (sparse_distance > 0) & net.mask;
    samples = usable.flatten(1).sum(1);
    if (options.align_to_sparse_depth) {
      factor = model::sparse_depth_alignment_scale(
          scale.view({batch, 1, 1}) * net.distance,
          at::where(usable, sparse_distance, at::zeros_like(sparse_distance)));
      scale = scale * factor;
    }
  }
  timing.alignment_ms += ms_since(start);

  std::vector<Prediction> predictions;
  const at::Tensor scale_cpu = scale.to(at::kCPU, at::kDouble),
                   factor_cpu = factor.to(at::kCPU, at::kDouble);
  const at::Tensor samples_cpu = samples.to(at::kCPU);
  for (int64_t b = 0; b < batch; ++b) {
    const double s = scale_cpu[b].item<double>();
    // A given camera is used as it is: its rays carry the predicted distances (pixels outside
    // its domain are invalid); the predicted rays stand in only for an unknown camera.
    const at::Tensor rays = camera_rays.defined() ? camera_rays[b] : net.rays[b];
    const at::Tensor mask = camera_rays.defined() ? net.mask[b] & camera_valid : net.mask[b];
    Prediction p = prediction_from_geometry(rays.to(at::kCPU, at::kFloat),
                                            (net.distance[b] * s).to(at::kCPU, at::kFloat),
                                            mask.to(at::kCPU), s);
    p.alignment_factor = factor_cpu[b].item<double>();
    p.sparse_samples = samples_cpu[b].item<int64_t>();
    p.notes = notes;
    start = Clock::now();
    p.fitted_camera = fit(options.fit_model, camera, p.rays, p.mask, &p.fit_error);
    p.timing = timing;
    p.timing.camera_fit_ms += ms_since(start);
    predictions.push_back(std::move(p));
  }
  return predictions;
}

at::Tensor sparse_distance_map(const SparseDepthInput& input, int64_t width, int64_t height,
                               const at::Tensor& rays, const camera::Camera* camera) {
  if (input.depth_map.defined()) {
    const at::Tensor depth = input.depth_map.to(at::kCPU, at::kFloat);
    if (depth.dim() != 2 || depth.size(0) != height || depth.size(1) != width)
      throw std::invalid_argument("sparse depth: the map is " + c10::str(depth.sizes()) +
                                  " but the image is " + std::to_string(height) + "x" +
                                  std::to_string(width) + " (H x W)");
    const at::Tensor present = at::isfinite(depth) & (depth > 0);
    const at::Tensor values = at::where(present, depth, at::zeros_like(depth));
    if (!input.depth_is_planar) return values;
    if (!rays.defined())
      throw std::invalid_argument("sparse depth: planar depth needs the rays of the image");
    const geometry::DistanceFromDepth distance =
        geometry::distance_from_planar_depth(values, rays.to(at::kCPU, at::kFloat));
    return at::where(distance.valid, distance.distance, at::zeros_like(values));
  }
  if (!input.lidar_points.defined()) return at::zeros({height, width});
  if (camera == nullptr)
    throw std::invalid_argument("sparse depth: a point cloud needs the camera to project through");
  at::Tensor points = input.lidar_points.to(at::kCPU, at::kDouble);
  if (points.dim() != 2 || points.size(1) != 3)
    throw std::invalid_argument("sparse depth: the point cloud must be (N, 3), got " +
                                c10::str(points.sizes()));
  if (input.camera_from_lidar.defined()) {
    const at::Tensor m = input.camera_from_lidar.to(at::kCPU, at::kDouble);
    if (m.sizes() != at::IntArrayRef{4, 4} || !at::isfinite(m).all().item<bool>())
      throw std::invalid_argument("sparse depth: camera-from-LiDAR must be a finite 4x4 matrix");
    points = points.matmul(m.slice(0, 0, 3).slice(1, 0, 3).t()) + m.slice(0, 0, 3).select(1, 3);
  }
  const camera::Camera image_camera = camera->width() == width && camera->height() == height
                                          ? *camera
                                          : camera_for_image(*camera, width, height);
  return geometry::sparse_depth_from_points(points, image_camera).depth.to(at::kFloat);
}

std::string auto_fit_model(const at::Tensor& rays, const at::Tensor& valid) {
  const at::Tensor z = rays.select(-1, 2).masked_select(valid);
  if (z.numel() == 0) return "PINHOLE";
  const double min_z = z.min().item<double>();
  if (min_z >= std::cos(70.0 * M_PI / 180.0)) return "PINHOLE";
  if (min_z > -0.95) return "OPENCV_FISHEYE";  // no lens sees within 18° of straight back
  return "EQUIRECTANGULAR";
}

Prediction prediction_from_geometry(const at::Tensor& rays, const at::Tensor& distance,
                                    const at::Tensor& mask, double metric_scale) {
  if (rays.dim() != 3 || rays.size(2) != 3 || distance.sizes() != rays.sizes().slice(0, 2) ||
      mask.sizes() != distance.sizes())
    throw std::invalid_argument(
        "prediction: expected rays (H, W, 3), distance (H, W) and mask (H, W), got " +
        c10::str(rays.sizes()) + ", " + c10::str(distance.sizes()) + ", " + c10::str(mask.sizes()));
  Prediction p;
  p.mask = mask.to(at::kBool) & at::isfinite(distance) & (distance > 0) & (rays.norm(2, -1) > 0.5);
  p.rays = at::where(at::isfinite(rays), rays, at::zeros_like(rays));
  p.distance = at::where(p.mask, distance, at::zeros_like(distance));
  p.points = geometry::points_from_rays(p.rays, p.distance);
  p.depth = geometry::planar_depth(p.points);
  p.metric_scale = metric_scale;
  return p;
}

}  // namespace omnipoint::predict
