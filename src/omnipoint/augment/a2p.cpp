#include "omnipoint/augment/a2p.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "omnipoint/augment/warp.h"

namespace omnipoint::augment {
namespace {

double uniform(at::Generator& generator, double lo, double hi) {
  return lo + (hi - lo) * at::rand({1}, generator, at::kDouble).item<double>();
}

// Whether the wide camera sees the view's optical axis.
bool sees_axis(const camera::Camera& wide, const PerspectiveView& view) {
  const at::Tensor axis = view.rotation.to(at::kDouble).select(1, 2).reshape({1, 3});
  const camera::Pixels p = wide.project(axis);
  return (p.valid & wide.inside_image(p.pixels)).item<bool>();
}

void check_image(const camera::Camera& wide, const at::Tensor& image, const std::string& where) {
  if (!image.defined() || image.dim() != 3 || image.size(0) != wide.height() ||
      image.size(1) != wide.width() || !at::isFloatingType(image.scalar_type())) {
    throw std::invalid_argument(
        where + ": the image must be a float (" + std::to_string(wide.height()) + ", " +
        std::to_string(wide.width()) + ", C) tensor matching the wide camera");
  }
}

}  // namespace

PerspectiveView make_perspective_view(double fov_deg, double yaw_deg, double pitch_deg,
                                      int64_t width, int64_t height, double roll_deg) {
  return {camera::centred_pinhole(fov_deg, width, height),
          rotation_from_angles(yaw_deg, pitch_deg, roll_deg)};
}

PerspectiveView sample_perspective_view(const camera::Camera& wide, const A2PViewDistribution& d,
                                        at::Generator generator) {
  if (!(d.min_fov_deg > 0 && d.max_fov_deg < 180 && d.min_fov_deg <= d.max_fov_deg) ||
      d.min_size < 8 || d.min_size > d.max_size) {
    throw std::invalid_argument(
        "sample_perspective_view: need 0 < min_fov <= max_fov < 180 and 8 <= min_size <= max_size");
  }
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const double fov = uniform(generator, d.min_fov_deg, d.max_fov_deg);
    const double aspect = uniform(generator, 0.75, 4.0 / 3.0);
    const auto long_side =
        static_cast<int64_t>(std::floor(uniform(generator, d.min_size, d.max_size + 1.0 - 1e-9)));
    const int64_t width =
        aspect >= 1 ? long_side : std::max<int64_t>(8, std::llround(long_side * aspect));
    const int64_t height =
        aspect >= 1 ? std::max<int64_t>(8, std::llround(long_side / aspect)) : long_side;
    // One draw a statement, pitch first: the order of two draws inside one call is the
    // compiler's, and the views have always been drawn in GCC's (right to left).
    const double pitch = uniform(generator, -d.max_pitch_deg, d.max_pitch_deg);
    const double yaw = uniform(generator, -180, 180);
    PerspectiveView view = make_perspective_view(fov, yaw, pitch, width, height);
    if (sees_axis(wide, view)) return view;
  }
  throw std::invalid_argument("sample_perspective_view: the wide camera " + wide.to_spec() +
                              " sees none of the sampled view directions");
}

ExtractedView extract_view(const camera::Camera& wide, const at::Tensor& image,
                           const PerspectiveView& view, const at::Tensor& wide_valid) {
  check_image(wide, image, "extract_view");
  const camera::Rays rays = view.camera.ray_map(image.options().dtype(at::kDouble));
  const at::Tensor wide_rays = rays.rays.matmul(view.rotation.to(at::kDouble).t());
  const camera::Pixels projected = wide.project(wide_rays);
  at::Tensor valid = rays.valid & projected.valid & wide.inside_image(projected.pixels);
  if (wide_valid.defined()) {
    if (wide_valid.sizes() != at::IntArrayRef({wide.height(), wide.width()}) ||
        wide_valid.scalar_type() != at::kBool) {
      throw std::invalid_argument(
          "extract_view: wide_valid must be a bool (H, W) map matching the wide camera");
    }
    const at::Tensor col =
        projected.pixels.select(-1, 0).floor().clamp(0, wide.width() - 1).to(at::kLong);
    const at::Tensor row =
        projected.pixels.select(-1, 1).floor().clamp(0, wide.height() - 1).to(at::kLong);
    valid = valid & wide_valid.to(projected.pixels.device())
                        .reshape(-1)
                        .index_select(0, (row * wide.width() + col).reshape(-1))
                        .view_as(valid);
  }
  const at::Tensor sampled = sample_image(image, projected.pixels);
  return {at::where(valid.unsqueeze(-1), sampled, at::zeros_like(sampled)), valid};
}

PseudoLabel stitch_view(const camera::Camera& wide, const PerspectiveView& view,
                        const TeacherPrediction& prediction, double tolerance) {
  const int64_t h = view.camera.height(), w = view.camera.width();
  if (!prediction.distance.defined() || prediction.distance.sizes() != at::IntArrayRef({h, w}) ||
      !prediction.confident.defined() ||
      prediction.confident.sizes() != prediction.distance.sizes() ||
      prediction.confident.scalar_type() != at::kBool) {
    throw std::invalid_argument("stitch_view: the prediction needs distance (" + std::to_string(h) +
                                ", " + std::to_string(w) +
                                ") and a bool confident map of the view's size");
  }
  const auto opts = prediction.distance.options().dtype(at::kDouble);
  const camera::Rays wide_rays = wide.ray_map(opts);
  const at::Tensor view_rays = wide_rays.rays.matmul(view.rotation.to(opts));  // Rᵀ r, row form
  const camera::Pixels projected = view.camera.project(view_rays);
  // The rays are unit and the centres shared, so the teacher's distance along its own ray
  // is the distance along the wide ray through the same point.
  const at::Tensor distance = prediction.distance.to(opts);
  const SampledDistance sampled =
      sample_distance(distance, prediction.confident & at::isfinite(distance) & (distance > 0),
                      projected.pixels, tolerance);
  const at::Tensor mask = wide_rays.valid & projected.valid & (view_rays.select(-1, 2) > 0) &
                          view.camera.inside_image(projected.pixels) & sampled.ok;
  const auto out_type = prediction.distance.scalar_type();
  return {at::where(mask, sampled.value, at::zeros_like(sampled.value)).to(out_type), mask};
}

A2PResult any_to_perspective(const camera::Camera& wide, const at::Tensor& image,
                             const PerspectiveView& view, const Teacher& teacher,
                             const at::Tensor& wide_valid, double tolerance) {
  A2PResult result{view, extract_view(wide, image, view, wide_valid), {}, {}};
  result.prediction = teacher(result.extracted.image, view.camera);
  if (!result.prediction.confident.defined())
    throw std::invalid_argument("any_to_perspective: the teacher gave no confident map");
  result.prediction.confident = result.prediction.confident & result.extracted.valid;
  result.label = stitch_view(wide, view, result.prediction, tolerance);
  return result;
}

std::vector<PerspectiveView> tiling_views(const camera::Camera& wide,
                                          const MultiViewOptions& options) {
  if (!(options.fov_deg > 0 && options.fov_deg < 180) || options.view_size < 8) {
    throw std::invalid_argument(
        "tiling_views: need 0 < fov < 180 degrees and a view size of at least 8");
  }
  std::vector<std::pair<double, double>> directions;  // (yaw, pitch)
  directions.reserve(18);
  for (int i = 0; i < 8; ++i) directions.emplace_back(-180.0 + 45.0 * i, 0.0);
  for (double pitch : {60.0, -60.0}) {
    for (int i = 0; i < 4; ++i) directions.emplace_back(-135.0 + 90.0 * i, pitch);
  }
  directions.emplace_back(0.0, 90.0);
  directions.emplace_back(0.0, -90.0);
  std::vector<PerspectiveView> views;
  for (const auto& [yaw, pitch] : directions) {
    PerspectiveView view =
        make_perspective_view(options.fov_deg, yaw, pitch, options.view_size, options.view_size);
    if (sees_axis(wide, view)) views.push_back(std::move(view));
  }
  return views;
}

MergedPrediction predict_wide_from_views(const camera::Camera& wide, const at::Tensor& image,
                                         const Teacher& teacher, const MultiViewOptions& options,
                                         const at::Tensor& wide_valid) {
  check_image(wide, image, "predict_wide_from_views");
  const std::vector<PerspectiveView> views = tiling_views(wide, options);
  std::vector<PseudoLabel> labels;
  std::vector<at::Tensor> weights;
  const auto opts = image.options().dtype(at::kDouble);
  const at::Tensor wide_rays = wide.ray_map(opts).rays;
  for (const auto& view : views) {
    const A2PResult one =
        any_to_perspective(wide, image, view, teacher, wide_valid, options.tolerance);
    // Blend weight: the cosine to the view axis, squared, so seams fall off smoothly.
    const at::Tensor cosine = wide_rays.matmul(view.rotation.to(opts).select(1, 2)).clamp_min(0);
    labels.push_back(one.label);
    weights.push_back(at::where(one.label.mask, cosine * cosine, at::zeros_like(cosine)));
  }
  const int64_t n = static_cast<int64_t>(views.size());
  MergedPrediction merged{at::zeros({wide.height(), wide.width()}, opts),
                          at::zeros({wide.height(), wide.width()}, opts.dtype(at::kBool)),
                          std::vector<double>(n, 1.0)};
  if (n == 0) return merged;
  at::Tensor numerator = at::zeros_like(merged.distance),
             denominator = at::zeros_like(merged.distance);
  std::vector<bool> done(n, false);
  for (int64_t step = 0; step < n; ++step) {
    const at::Tensor covered = denominator > 0;
    int64_t best = -1, best_overlap = -1, best_size = -1;
    for (int64_t k = 0; k < n; ++k) {
      if (done[k]) continue;
      const int64_t overlap = (labels[k].mask & covered).sum().item<int64_t>();
      const int64_t size = labels[k].mask.sum().item<int64_t>();
      if (overlap > best_overlap || (overlap == best_overlap && size > best_size)) {
        best = k, best_overlap = overlap, best_size = size;
      }
    }
    done[best] = true;
    const at::Tensor label = labels[best].distance.to(at::kDouble);
    double scale = 1.0;
    if (best_overlap >= options.min_overlap) {
      const at::Tensor overlap = labels[best].mask & covered;
      const at::Tensor ratio = (numerator / denominator.clamp_min(1e-300)).masked_select(overlap) /
                               label.masked_select(overlap);
      scale = ratio.median().item<double>();
    }
    merged.view_scales[best] = scale;
    numerator = numerator + weights[best] * label * scale;
    denominator = denominator + weights[best];
  }
  merged.mask = denominator > 0;
  merged.distance =
      at::where(merged.mask, numerator / denominator.clamp_min(1e-300), at::zeros_like(numerator))
          .to(image.scalar_type());
  return merged;
}

}  // namespace omnipoint::augment
