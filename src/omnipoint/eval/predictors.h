#pragma once
// Predictors for the benchmark runner (runner.h): networks, external point maps, and two
// reference "models" that bracket every score.
//   network:    infer::run (the inference path `omnipoint predict` ships) with the mode's
//               conditions: +K gives the sample's camera (OmniPoint only: it is no input to
//               MoGe-2), +D the sampled GT distances, which also align the metric scale on
//               metric samples (geometry::fit_scale_to_sparse_depth, the paper's post-alignment).
//               MoGe-2's points give rays and distances; not metric without a scale head.
//               Scored: the point map predict ships (infer::point_map, zero outside its mask).
//   point maps: an (H, W, 3) metric point map per sample (external predictions); rays and
//               distances are its directions and norms (zero / non-finite points: no ray).
//   oracle:     the ground truth's own rays and distances (scores Rel 0, δ1 1 everywhere).
//   constant:   the GT camera's rays with one constant distance for every pixel, metric:
//               the score of knowing the camera but nothing about the scene; with sparse
//               depth the constant is the median of the samples (a scale-only use of +D).
//   median map: the GT camera's rays with, per pixel, the median of the distances a training
//               set labels there through the same camera: the picture-blind map of what the
//               camera and the typical scene give without looking at the image (floor below,
//               far above), metric; with sparse depth it is rescaled by the median ratio of
//               the samples to the map (a scale-only use of +D).
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "omnipoint/eval/runner.h"
#include "omnipoint/infer/infer.h"

namespace omnipoint::eval {

// num_tokens 0: the model's default (infer::Network::default_num_tokens).
Predictor network_predictor(infer::Network network, const std::string& name, int64_t num_tokens = 0,
                            model::Precision precision = model::Precision::kFloat32);
// `load` returns the sample's point map or throws MissingPrediction.
Predictor point_map_predictor(const std::string& name,
                              std::function<at::Tensor(const EvalSample&)> load);
Predictor oracle_predictor();
Predictor constant_distance_predictor(double distance);
// The maps of every camera (by its COLMAP spec) of the datasets' samples (data/dataset_index.h;
// read here). A sample whose camera none of them has gets MissingPrediction. Datasets without
// samples -> std::runtime_error.
Predictor median_map_predictor(const std::vector<std::string>& datasets);

// Rays and distances of a point map (..., 3): directions and norms; points that are zero or
// not finite get a zero ray and distance 0.
GeometryPrediction prediction_from_points(const at::Tensor& points, bool is_metric);

}  // namespace omnipoint::eval
