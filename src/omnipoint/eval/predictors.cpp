#include "omnipoint/eval/predictors.h"

#include <ATen/ATen.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>
#include <stdexcept>
#include <utility>

#include "omnipoint/data/dataset_index.h"
#include "omnipoint/geometry/points.h"

namespace omnipoint::eval {

GeometryPrediction prediction_from_points(const at::Tensor& points, bool is_metric) {
  const geometry::RaysAndDistance factored = geometry::rays_from_points(points);
  GeometryPrediction prediction;
  prediction.rays = factored.rays;
  prediction.distance = factored.distance;
  prediction.is_metric = is_metric;
  return prediction;
}

Predictor network_predictor(infer::Network network, const std::string& name, int64_t num_tokens,
                            model::Precision precision) {
  Predictor predictor;
  predictor.name = name;
  predictor.accepts_intrinsics = static_cast<bool>(network.omnipoint());
  predictor.accepts_sparse_depth = true;
  predictor.predict = [network = std::move(network), num_tokens, precision](
                          const EvalSample& item, const Conditions& conditions) {
    infer::Inputs inputs;
    inputs.images = item.sample.image.permute({2, 0, 1}).unsqueeze(0);
    if (conditions.rays.defined()) inputs.camera = item.sample.camera;
    if (conditions.sparse_depth.defined())
      inputs.sparse_distance = conditions.sparse_depth.unsqueeze(0);
    inputs.num_tokens = num_tokens;
    inputs.precision = precision;
    // Distances of a relative (non-metric) sample carry no metric scale to align to.
    inputs.align_to_sparse_depth = item.sample.metric;
    const infer::Result result = infer::run(network, inputs);
    const infer::PointMap& shipped = result.shipped;
    GeometryPrediction prediction;
    prediction.rays = shipped.rays[0].to(at::kCPU, at::kFloat);
    prediction.distance =
        at::where(shipped.mask, result.distance, at::zeros_like(result.distance))[0].to(at::kCPU,
                                                                                        at::kFloat);
    prediction.metric_scale = result.metric_scale[0].item<double>();
    prediction.is_metric = result.metric;
    prediction.points = shipped.points[0].to(at::kCPU, at::kFloat);
    return prediction;
  };
  return predictor;
}

Predictor point_map_predictor(const std::string& name,
                              std::function<at::Tensor(const EvalSample&)> load) {
  Predictor predictor;
  predictor.name = name;
  predictor.predict = [load = std::move(load)](const EvalSample& item, const Conditions&) {
    return prediction_from_points(load(item).to(at::kFloat), true);
  };
  return predictor;
}

Predictor oracle_predictor() {
  Predictor predictor;
  predictor.name = "oracle (GT rays and distances)";
  predictor.accepts_intrinsics = true;
  predictor.accepts_sparse_depth = true;
  predictor.predict = [](const EvalSample& item, const Conditions&) {
    GeometryPrediction prediction;
    prediction.rays = item.sample.camera.ray_map(at::kFloat).rays;
    prediction.distance = item.sample.distance;
    prediction.is_metric = item.sample.metric;
    return prediction;
  };
  return predictor;
}

Predictor constant_distance_predictor(double distance) {
  if (!(distance > 0) || !std::isfinite(distance))
    throw std::invalid_argument("constant distance " + std::to_string(distance) +
                                ": expected > 0 metres");
  Predictor predictor;
  char label[64];
  std::snprintf(label, sizeof label, "constant distance %g m (GT rays)", distance);
  predictor.name = label;
  predictor.accepts_intrinsics = true;
  predictor.accepts_sparse_depth = true;
  predictor.predict = [distance](const EvalSample& item, const Conditions& conditions) {
    double value = distance;
    if (conditions.sparse_depth.defined()) {
      const at::Tensor samples = conditions.sparse_depth.masked_select(conditions.sparse_depth > 0);
      if (samples.numel() > 0) value = samples.median().item<double>();
    }
    GeometryPrediction prediction;
    prediction.rays = item.sample.camera.ray_map(at::kFloat).rays;
    prediction.distance = at::full_like(item.sample.distance, value);
    prediction.is_metric = true;
    return prediction;
  };
  return predictor;
}

Predictor median_map_predictor(const std::vector<std::string>& datasets) {
  // Per camera spec: the labelled distances of its samples, NaN where unlabelled.
  std::map<std::string, std::vector<at::Tensor>> distances;
  for (const std::string& root : datasets)
    for (const data::DatasetItem& item : data::list_dataset(root)) {
      const data::Sample sample = data::read_dataset_item(item, true);
      distances[sample.camera.to_spec()].push_back(
          at::where(sample.mask, sample.distance, at::full_like(sample.distance, NAN)));
    }
  auto maps = std::make_shared<std::map<std::string, at::Tensor>>();
  for (const auto& [spec, stack] : distances) {
    at::Tensor map = std::get<0>(at::stack(stack).nanmedian(0));
    // A pixel no sample labels (the sky of every scene) gets the map's median, so that the
    // prediction stays finite; the GT rarely labels it either.
    const at::Tensor labelled = at::isfinite(map);
    const double fill =
        labelled.any().item<bool>() ? map.masked_select(labelled).median().item<double>() : 1.0;
    (*maps)[spec] = at::where(labelled, map, at::full_like(map, fill)).contiguous();
  }
  Predictor predictor;
  predictor.name = "median distance map (GT rays)";
  predictor.accepts_intrinsics = true;
  predictor.accepts_sparse_depth = true;
  predictor.predict = [maps](const EvalSample& item, const Conditions& conditions) {
    const auto found = maps->find(item.sample.camera.to_spec());
    if (found == maps->end())
      throw MissingPrediction("no sample of the baseline data has the camera " +
                              item.sample.camera.to_spec());
    at::Tensor map = found->second;
    if (conditions.sparse_depth.defined()) {
      const at::Tensor given = conditions.sparse_depth > 0;
      if (given.any().item<bool>())
        map = map * (conditions.sparse_depth.masked_select(given) / map.masked_select(given))
                        .median()
                        .item<double>();
    }
    GeometryPrediction prediction;
    prediction.rays = item.sample.camera.ray_map(at::kFloat).rays;
    prediction.distance = map;
    prediction.is_metric = true;
    return prediction;
  };
  return predictor;
}

}  // namespace omnipoint::eval
