// omnipoint metrics: scores a depth (and optionally point) map prediction with MoGe's
// protocol and prints one JSON object {entry: {"rel": ..., "delta1": ...}} (NaN as null).
// Warnings about undefined entries go to stderr.
#include <ATen/ATen.h>
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "omnipoint/eval/metrics.h"
#include "omnipoint/io/npy.h"

namespace omnipoint::cli {
namespace {

struct MetricsOptions {
  std::string gt_depth, pred_depth, gt_points, pred_points, mask;
  bool metric = false;
};

std::string shape_of(const at::Tensor& t) {
  std::string s = "(";
  for (int64_t i = 0; i < t.dim(); ++i) s += (i ? ", " : "") + std::to_string(t.size(i));
  return s + ")";
}

// Reads a float32/float64 map of H×W (channels = 0) or H×W×channels.
at::Tensor read_map(const std::string& path, const std::string& option, int64_t channels) {
  at::Tensor t = io::read_npy(path);
  if (t.scalar_type() != at::kFloat && t.scalar_type() != at::kDouble) {
    throw std::invalid_argument(option + " " + path +
                                ": expected a float32 or float64 array, got dtype " +
                                std::string(c10::toString(t.scalar_type())));
  }
  const bool ok = channels == 0 ? t.dim() == 2 : (t.dim() == 3 && t.size(2) == channels);
  if (!ok) {
    throw std::invalid_argument(option + " " + path + ": expected shape " +
                                (channels ? "(H, W, 3)" : "(H, W)") + ", got " + shape_of(t));
  }
  return t;
}

void require_size(const at::Tensor& t, const at::Tensor& reference, const std::string& option,
                  const std::string& path) {
  if (t.size(0) != reference.size(0) || t.size(1) != reference.size(1)) {
    throw std::invalid_argument(option + " " + path + ": size " + shape_of(t) +
                                " does not match --gt-depth " + shape_of(reference));
  }
}

void run_metrics(const MetricsOptions& o) {
  if (o.gt_points.empty() != o.pred_points.empty()) {
    throw std::invalid_argument("--gt-points and --pred-points must be given together");
  }
  eval::GroundTruth gt;
  eval::Prediction pred;
  gt.depth = read_map(o.gt_depth, "--gt-depth", 0);
  pred.depth = read_map(o.pred_depth, "--pred-depth", 0);
  require_size(pred.depth, gt.depth, "--pred-depth", o.pred_depth);
  if (!o.gt_points.empty()) {
    gt.points = read_map(o.gt_points, "--gt-points", 3);
    pred.points = read_map(o.pred_points, "--pred-points", 3);
    require_size(gt.points, gt.depth, "--gt-points", o.gt_points);
    require_size(pred.points, gt.depth, "--pred-points", o.pred_points);
  }
  if (o.mask.empty()) {
    gt.mask = at::logical_and(at::isfinite(gt.depth), gt.depth > 0);  // 0 / inf / nan are invalid
  } else {
    const at::Tensor mask = io::read_npy(o.mask);
    if (mask.scalar_type() != at::kByte && mask.scalar_type() != at::kBool) {
      throw std::invalid_argument("--mask " + o.mask +
                                  ": expected a uint8 or bool array, got dtype " +
                                  std::string(c10::toString(mask.scalar_type())));
    }
    if (mask.dim() != 2)
      throw std::invalid_argument("--mask " + o.mask + ": expected shape (H, W), got " +
                                  shape_of(mask));
    require_size(mask, gt.depth, "--mask", o.mask);
    gt.mask = mask != 0;
  }
  gt.is_metric = pred.is_metric = o.metric;

  const eval::Metrics metrics = eval::compute_metrics(pred, gt);
  for (const std::string& warning : metrics.warnings)
    std::cerr << "omnipoint: warning: " << warning << "\n";
  nlohmann::ordered_json out = nlohmann::ordered_json::object();
  for (const char* name : eval::kMetricEntries) {
    const auto it = metrics.entries.find(name);
    if (it == metrics.entries.end()) continue;
    out[name] = {{"rel", it->second.rel}, {"delta1", it->second.delta1}};
  }
  std::cout << out.dump(2) << std::endl;
}

}  // namespace

void add_metrics_command(CLI::App& app) {
  auto options = std::make_shared<MetricsOptions>();
  CLI::App* cmd = app.add_subcommand(
      "metrics",
      "Score a depth (and point map) prediction with MoGe's protocol; prints one JSON object");
  cmd->add_option("--gt-depth", options->gt_depth, "ground-truth depth, H×W .npy")->required();
  cmd->add_option("--pred-depth", options->pred_depth, "predicted depth, H×W .npy")->required();
  cmd->add_option("--gt-points", options->gt_points,
                  "ground-truth points, H×W×3 .npy (with --pred-points)");
  cmd->add_option("--pred-points", options->pred_points,
                  "predicted points, H×W×3 .npy (with --gt-points)");
  cmd->add_option("--mask", options->mask,
                  "valid pixels, H×W uint8/bool .npy (default: finite ground-truth depth > 0)");
  cmd->add_flag("--metric", options->metric,
                "ground truth and prediction are metric: add the metric entries");
  cmd->callback([options] { run_metrics(*options); });
}

}  // namespace omnipoint::cli
