// Model::load / predict: the user's image, camera and sparse depth prepared for infer::run (the
// one inference path), then the camera fit and the packaging into CPU predictions.
#include "omnipoint/predict/predictor.h"

#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "omnipoint/camera/fit.h"
#include "omnipoint/geometry/grid_surface.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/infer/infer.h"

namespace omnipoint::predict {

struct Model::Impl {
  infer::Network network;
};

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// (B,H,W,3) images -> (B,3,H,W) float32 in [0,1] on the device, the layout infer::run takes.
at::Tensor network_input(const at::Tensor& images, at::Device device) {
  if (images.dim() != 4 || images.size(3) != 3 || images.size(1) < 1 || images.size(2) < 1)
    throw std::invalid_argument("predict: expected images (H, W, 3) or (B, H, W, 3) RGB, got " +
                                c10::str(images.sizes()));
  at::Tensor input = images.to(device);
  input = input.scalar_type() == at::kByte ? input.to(at::kFloat) / 255.0 : input.to(at::kFloat);
  if (!at::isfinite(input).all().item<bool>() || input.min().item<float>() < 0 ||
      input.max().item<float>() > 1)
    throw std::invalid_argument("predict: image values must be finite RGB in [0, 1]");
  return input.permute({0, 3, 1, 2}).contiguous();
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

// `model` ("auto": camera::fit_camera_auto's choice) fitted to the rays at the valid pixels of
// `mask`; nullopt with *error set when it does not fit.
std::optional<camera::CameraFit> fit(const std::string& model, const at::Tensor& rays,
                                     const at::Tensor& mask, std::string* error) {
  const at::Tensor valid = mask & (rays.norm(2, -1) > 0.5);
  const int64_t width = rays.size(1), height = rays.size(0);
  try {
    return model == "auto" ? camera::fit_camera_auto(width, height, rays, valid)
                           : camera::fit_camera_model(model, width, height, rays, valid);
  } catch (const std::invalid_argument& e) {
    *error = e.what();
    return std::nullopt;
  }
}

// The prediction's camera: a given one as it is (the output rays are its rays) unless
// another model is asked for; otherwise the fit of `requested` ("" = none).
void attach_camera(const std::string& requested, const std::optional<camera::Camera>& given,
                   CameraSource given_source, Prediction* p) {
  if (given && (requested.empty() || requested == "auto" || requested == given->model_name())) {
    p->fitted_camera = given;
    p->camera_source = given_source;
    return;
  }
  if (requested.empty()) return;
  if (auto fitted = fit(requested, p->rays, p->mask, &p->fit_error)) {
    p->fitted_camera = std::move(fitted->camera);
    p->fit_residual = fitted->residual;
    p->camera_source = CameraSource::kFitted;
  }
}

// One image's Prediction from its shipped geometry (infer::point_map: the masking rule).
Prediction prediction(const infer::PointMap& map, double metric_scale) {
  Prediction p;
  p.rays = map.rays;
  p.distance = map.distance;
  p.points = map.points;
  p.mask = map.mask;
  p.depth = geometry::planar_depth(p.points);
  p.metric_scale = metric_scale;
  return p;
}

}  // namespace

const char* camera_source_name(CameraSource source) {
  switch (source) {
    case CameraSource::kGiven:
      return "given";
    case CameraSource::kExif:
      return "exif";
    case CameraSource::kFitted:
      return "fitted";
    default:
      return "none";
  }
}

CameraSource camera_source_of(const Prediction& p) {
  if (!p.fitted_camera) return CameraSource::kNone;
  if (p.camera_source != CameraSource::kNone) return p.camera_source;
  return p.fit_residual ? CameraSource::kFitted : CameraSource::kGiven;
}

Model Model::load(const std::string& path, at::Device device) {
  return Model(std::make_shared<Impl>(Impl{infer::load_network(path, device)}));
}

const std::string& Model::format() const {
  return impl_->network.format();
}
at::Device Model::device() const {
  return impl_->network.device();
}
int64_t Model::default_num_tokens() const {
  return impl_->network.default_num_tokens();
}
const infer::Network& Model::network() const {
  return impl_->network;
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
  const infer::Network& network = impl_->network;
  StageTimes timing;
  std::vector<std::string> notes;

  // Prepare: the images once to the device in the network's layout, the camera at their size.
  auto start = Clock::now();
  infer::Inputs inputs;
  inputs.images = network_input(images, network.device());
  inputs.num_tokens = options.num_tokens;
  inputs.precision = options.precision;
  inputs.align_to_sparse_depth = options.align_to_sparse_depth;
  const int64_t batch = inputs.images.size(0), height = inputs.images.size(2),
                width = inputs.images.size(3);
  const SparseDepthInput& sparse = options.sparse_depth;
  if (sparse.lidar_points.defined() && batch != 1)
    throw std::invalid_argument("predict: a point-cloud sparse depth needs a batch of one image");
  if (sparse.depth_map.defined() &&
      (sparse.depth_map.dim() != 3 || sparse.depth_map.size(0) != batch))
    throw std::invalid_argument(
        "predict: the sparse depth maps must be (B, H, W) with B = " + std::to_string(batch) +
        ", got " + c10::str(sparse.depth_map.sizes()));
  if (options.camera) inputs.camera = camera_for_image(*options.camera, width, height);
  timing.prepare_ms += ms_since(start);

  // The sparse depth as radial distances needs rays (planar maps) or a camera (point clouds);
  // without a given camera they come from a first run without sparse depth.
  at::Tensor sparse_in_image;  // (B) pixels with a sample
  if (!sparse.empty()) {
    at::Tensor rays;  // (B,H,W,3)
    std::optional<camera::Camera> projection = inputs.camera;
    const bool needs_rays = sparse.depth_map.defined() && sparse.depth_is_planar;
    if (inputs.camera && needs_rays) {
      rays = inputs.camera->ray_map(at::kFloat).rays.unsqueeze(0).expand({batch, height, width, 3});
    } else if (!inputs.camera && (needs_rays || sparse.lidar_points.defined())) {
      const infer::Result first = infer::run(network, inputs);
      timing.network_ms += first.timing.network_ms;
      rays = first.rays.to(at::kCPU);
      if (sparse.lidar_points.defined()) {
        start = Clock::now();
        std::string error;
        const auto fitted = fit("auto", rays[0], first.mask[0].to(at::kCPU), &error);
        timing.camera_fit_ms += ms_since(start);
        if (fitted) projection = fitted->camera;
        if (!projection)
          throw std::invalid_argument(
              "predict: no camera to project the point cloud through (none given, and the "
              "predicted rays fit none: " +
              error + "); pass the camera");
      }
      notes.emplace_back(
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
                                         projection ? &*projection : nullptr));
    }
    inputs.sparse_distance = at::stack(maps).to(network.device());
    sparse_in_image = (inputs.sparse_distance > 0).flatten(1).sum(1).to(at::kCPU);
    timing.prepare_ms += ms_since(start);
  }

  // Network and alignment.
  const infer::Result result = infer::run(network, inputs);
  timing.network_ms += result.timing.network_ms;
  timing.alignment_ms += result.timing.alignment_ms;
  notes.insert(notes.end(), result.notes.begin(), result.notes.end());

  // Camera fit and packaging: to the CPU once, then per image.
  const infer::PointMap& shipped = result.shipped;
  const at::Tensor rays = shipped.rays.to(at::kCPU, at::kFloat),
                   distance = shipped.distance.to(at::kCPU, at::kFloat),
                   points = shipped.points.to(at::kCPU, at::kFloat),
                   mask = shipped.mask.to(at::kCPU),
                   scale = result.metric_scale.to(at::kCPU, at::kDouble),
                   factor = result.alignment_factor.to(at::kCPU, at::kDouble),
                   samples = result.sparse_samples.to(at::kCPU);
  const at::Tensor network_rays = result.predicted_rays.defined()
                                      ? result.predicted_rays.to(at::kCPU, at::kFloat)
                                      : at::Tensor();
  std::vector<Prediction> predictions;
  for (int64_t b = 0; b < batch; ++b) {
    Prediction p = prediction({rays[b], distance[b], points[b], mask[b]}, scale[b].item<double>());
    p.alignment_factor = factor[b].item<double>();
    p.sparse_samples = samples[b].item<int64_t>();
    p.notes = notes;
    p.precision = options.precision;
    if (sparse_in_image.defined())
      p.warnings = sparse_depth_warnings(
          sparse_in_image[b].item<int64_t>(),
          sparse.lidar_points.defined() ? sparse.lidar_points.size(0) : 0, p.sparse_samples,
          p.alignment_factor, options.sparse_depth_is_metric, sparse.placement_advice);
    // Before the flying-pixel filter, as the fit's residual.
    if (network_rays.defined() && inputs.camera && p.mask.any().item<bool>())
      p.camera_agreement = camera::angular_residual(*inputs.camera, network_rays[b], p.mask);
    start = Clock::now();
    attach_camera(options.fit_model, inputs.camera, options.camera_source, &p);
    p.timing = timing;
    p.timing.camera_fit_ms += ms_since(start);
    // After the fit: flying pixels have wrong distances but their rays are as good as any.
    remove_depth_edges(p, options.edge_rtol);
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
    at::Tensor values = at::where(present, depth, at::zeros_like(depth));
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
  // A sensor's sweep, compared with the prediction at pixel centres (sparse_sampling.h).
  return geometry::sparse_depth_from_points(points, image_camera, {},
                                            geometry::SparseValue::Distance,
                                            geometry::PointSelection::kSensorSweep)
      .depth.to(at::kFloat);
}

std::vector<std::string> sparse_depth_warnings(int64_t in_image, int64_t cloud_points, int64_t used,
                                               double alignment_factor, bool sparse_depth_is_metric,
                                               const std::string& placement_advice) {
  std::vector<std::string> warnings;
  const auto count = [](int64_t n) { return std::to_string(n); };
  if (cloud_points > 0 && (in_image < 20 || in_image * 200 < cloud_points))
    warnings.push_back("only " + count(in_image) + " of the point cloud's " + count(cloud_points) +
                       " points land in the image: is the cloud in the camera frame? (" +
                       placement_advice + ")");
  if (used == 0) {
    warnings.emplace_back(
        "no sparse depth sample falls where the prediction is valid: the metric "
        "scale is the network's own, not aligned");
  } else if (sparse_depth_is_metric && (alignment_factor > 3.0 || alignment_factor < 1.0 / 3.0)) {
    std::ostringstream factor;
    factor.precision(3);
    factor << alignment_factor;
    warnings.push_back("the sparse depth's scale disagrees with the prediction's by a factor of " +
                       factor.str() +
                       ": check its units (--depth-scale: 1000 for millimetre PNGs, 256 for KITTI) "
                       "and the LiDAR transform");
  }
  return warnings;
}

void remove_depth_edges(Prediction& p, double rtol) {
  if (rtol <= 0) return;
  const at::Tensor edges = geometry::depth_edge_mask(p.distance, p.mask, rtol);
  p.edge_rtol = rtol;
  p.edge_pixels_removed = edges.sum().item<int64_t>();
  if (p.edge_pixels_removed == 0) return;
  p.mask = p.mask & ~edges;
  p.distance = p.distance.masked_fill(edges, 0);
  p.points = p.points.masked_fill(edges.unsqueeze(-1), 0);
  p.depth = geometry::planar_depth(p.points);
}

void apply_metric_scale(Prediction& p, double metric_scale) {
  if (!(metric_scale > 0) || !std::isfinite(metric_scale))
    throw std::invalid_argument("apply_metric_scale: expected a positive scale, got " +
                                std::to_string(metric_scale));
  const double factor = metric_scale / p.metric_scale;
  p.distance = p.distance * factor;
  p.points = p.points * factor;
  p.depth = p.depth * factor;
  p.metric_scale = metric_scale;
}

Prediction prediction_from_geometry(const at::Tensor& rays, const at::Tensor& distance,
                                    const at::Tensor& mask, double metric_scale) {
  if (rays.dim() != 3 || rays.size(2) != 3 || distance.sizes() != rays.sizes().slice(0, 2) ||
      mask.sizes() != distance.sizes())
    throw std::invalid_argument(
        "prediction: expected rays (H, W, 3), distance (H, W) and mask (H, W), got " +
        c10::str(rays.sizes()) + ", " + c10::str(distance.sizes()) + ", " + c10::str(mask.sizes()));
  return prediction(infer::point_map(rays, distance, mask), metric_scale);
}

}  // namespace omnipoint::predict
