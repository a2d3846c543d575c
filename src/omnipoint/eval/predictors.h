#pragma once
// Predictors for the benchmark runner (runner.h): the two network kinds, external point maps,
// and two reference "models" that bracket every score.
//   omnipoint:  OmniPointModel::forward with the mode's conditions (ray map, sparse distances);
//               with sparse depth on a metric sample, the metric scale is post-aligned to it
//               (align_to_metric_sparse_depth, as the paper does).
//   moge2:      MoGe-2's infer() (no conditions); its points give rays and distances; not
//               metric without a scale head.
//   point maps: an (H, W, 3) metric point map per sample (external predictions); rays and
//               distances are its directions and norms (zero / non-finite points: no ray).
//   oracle:     the ground truth's own rays and distances (scores Rel 0, δ1 1 everywhere).
//   constant:   the GT camera's rays with one constant distance for every pixel, metric:
//               the score of knowing the camera but nothing about the scene; with sparse
//               depth the constant is the median of the samples (a scale-only use of +D).
#include <cstdint>
#include <functional>
#include <string>

#include "omnipoint/eval/runner.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/omnipoint_model.h"

namespace omnipoint::eval {

// num_tokens 0: the image's native token count, H·W / patch² (at least 1).
Predictor omnipoint_predictor(model::OmniPointModel model, const std::string& name,
                              int64_t num_tokens = 0, at::Device device = at::kCPU);
Predictor moge2_predictor(model::MoGe2Model model, const std::string& name, int64_t num_tokens = 0,
                          at::Device device = at::kCPU);
// `load` returns the sample's point map or throws MissingPrediction.
Predictor point_map_predictor(const std::string& name,
                              std::function<at::Tensor(const EvalSample&)> load);
Predictor oracle_predictor();
Predictor constant_distance_predictor(double distance);

// Rays and distances of a point map (..., 3): directions and norms; points that are zero or
// not finite get a zero ray and distance 0.
GeometryPrediction prediction_from_points(const at::Tensor& points, bool is_metric);

}  // namespace omnipoint::eval
