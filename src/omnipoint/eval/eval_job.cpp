#include "omnipoint/eval/eval_job.h"

#include <ATen/ATen.h>

#include <filesystem>
#include <stdexcept>
#include <utility>

#include "omnipoint/eval/predictors.h"
#include "omnipoint/infer/infer.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/model/omnipoint_config.h"

namespace omnipoint::eval {
namespace {
namespace fs = std::filesystem;

std::string label_or(const EvalJobOptions& options, const std::string& name) {
  return options.label.empty() ? name : options.label;
}

// DIR/<id>.npy, else DIR/<dataset folder name>/<id>.npy: (H, W, 3) metric points.
Predictor external_predictor(const EvalJobOptions& options) {
  const fs::path root(options.predictions);
  return point_map_predictor(
      label_or(options, root.filename().string()), [root](const EvalSample& item) {
        fs::path path = root / (item.id + ".npy");
        if (!fs::exists(path)) path = root / fs::path(item.dataset).filename() / (item.id + ".npy");
        if (!fs::exists(path))
          throw MissingPrediction("no prediction " + (root / (item.id + ".npy")).string());
        at::Tensor points = io::read_npy(path.string());
        if (points.dim() != 3 || points.size(2) != 3 || !at::isFloatingType(points.scalar_type()))
          throw std::invalid_argument(path.string() + ": expected a float (H, W, 3) point map");
        return points;
      });
}

// An untrained OmniPoint model of a config file, initialised from the seed: the chance-level
// row until trained weights exist.
Predictor random_model_predictor(const EvalJobOptions& options) {
  const auto config = model::OmniPointConfig::from_json_text(io::read_file(options.random_model));
  at::manual_seed(options.seed);
  const std::string name = fs::path(options.random_model).stem().string() + " (random weights)";
  return network_predictor(infer::Network(model::OmniPointModel(config), options.device),
                           label_or(options, name), options.num_tokens, options.precision);
}

Predictor make_predictor(const EvalJobOptions& options) {
  if (!options.model.empty())
    return network_predictor(infer::load_network(options.model, options.device),
                             label_or(options, fs::path(options.model).stem().string()),
                             options.num_tokens, options.precision);
  if (!options.random_model.empty()) return random_model_predictor(options);
  if (!options.predictions.empty()) return external_predictor(options);
  Predictor predictor;
  if (options.baseline == "oracle") predictor = oracle_predictor();
  if (options.baseline == "constant")
    predictor = constant_distance_predictor(options.constant_distance);
  if (options.baseline == "median") predictor = median_map_predictor(options.baseline_data);
  if (!options.label.empty()) predictor.name = options.label;
  return predictor;
}

// OUT/points/<dataset folder>/<id>/<mode>/: the point map scored and the sparse distances given.
void save_points(const fs::path& out, const EvalSample& item, const Mode& mode,
                 const Conditions& conditions, const GeometryPrediction& prediction) {
  fs::path dataset = fs::path(item.dataset).lexically_normal();
  if (dataset.filename().empty()) dataset = dataset.parent_path();
  const fs::path folder = out / "points" / dataset.filename() / item.id / mode.name();
  fs::create_directories(folder);
  io::write_npy((folder / "points.npy").string(), scored_points(prediction));
  if (conditions.sparse_depth.defined())
    io::write_npy((folder / "sparse_distance.npy").string(),
                  conditions.sparse_depth.to(at::kFloat).contiguous());
}

}  // namespace

void EvalJobOptions::Check() const {
  const int given =
      !model.empty() + !random_model.empty() + !predictions.empty() + !baseline.empty();
  if (given != 1)
    throw std::invalid_argument(
        "give exactly one of --model, --random-model, --predictions, --baseline");
  if (!baseline.empty() && baseline != "oracle" && baseline != "constant" && baseline != "median")
    throw std::invalid_argument("--baseline " + baseline + ": expected oracle, constant or median");
  if (baseline != "median" && !baseline_data.empty())
    throw std::invalid_argument("--baseline-data is for --baseline median only");
  if (baseline == "median" && baseline_data.empty())
    throw std::invalid_argument(
        "--baseline median needs --baseline-data: the training samples of the cameras");
  if (!predictions.empty() && !fs::is_directory(predictions))
    throw std::invalid_argument("--predictions " + predictions + ": not a folder");
  if (num_tokens < 0)
    throw std::invalid_argument("--num-tokens " + std::to_string(num_tokens) + ": expected >= 0");
  if (suite.empty() && data.empty()) throw std::invalid_argument("--data: no dataset folder given");
  if (!suite.empty() && !data.empty())
    throw std::invalid_argument("give either --data (datasets) or --suite (a benchmark suite)");
  if (!suite.empty() && suite_root.empty())
    throw std::invalid_argument("--suite needs --root: the folder holding the suite's sets");
  if (suite.empty() && !suite_root.empty())
    throw std::invalid_argument("--root is for --suite only (datasets are given by --data)");
  if (format.empty() && (!split.empty() || !format_options.empty()))
    throw std::invalid_argument("--split and --option need --format (the datasets' format)");
  if (!suite.empty() && !format.empty())
    throw std::invalid_argument("--format is for --data; a suite names each set's format");
  if (sparse_depth_points < 1)
    throw std::invalid_argument("--sparse-depth " + std::to_string(sparse_depth_points) +
                                ": expected a count >= 1");
  if (output_dir.empty()) throw std::invalid_argument("--out: no output folder given");
}

EvalJob::EvalJob(EvalJobOptions options, EvalJobObserver* observer)
    : options_(std::move(options)), observer_(observer) {}

EvalJobResult EvalJob::Run() {
  options_.Check();
  RunOptions run;
  run.modes = evaluation_modes(options_.intrinsics, options_.sparse_depth);
  run.sparse_depth_points = options_.sparse_depth_points;
  run.seed = options_.seed;
  run.moge_metric = options_.moge_metric;
  if (observer_ != nullptr)
    run.progress = [this](int64_t done, int64_t total, double seconds) {
      observer_->progress(done, total, seconds);
    };
  if (options_.save_points)
    run.scored = [out = fs::path(options_.output_dir)](const EvalSample& item, const Mode& mode,
                                                       const Conditions& conditions,
                                                       const GeometryPrediction& prediction) {
      save_points(out, item, mode, conditions, prediction);
    };
  EvalJobResult result;
  if (!options_.suite.empty()) {
    const Suite suite = read_suite(options_.suite);
    SuiteRunOptions suite_run;
    suite_run.root = options_.suite_root;
    suite_run.modes = std::move(run.modes);
    suite_run.run = std::move(run);
    const Predictor predictor = make_predictor(options_);
    result.predictor = predictor.name;
    result.suite = run_suite(predictor, suite, suite_run);
    result.table = write_suite_files(options_.output_dir, *result.suite);
    return result;
  }
  std::vector<EvalDataset> datasets;
  for (const std::string& root : options_.data) {
    data::DatasetLocation location{root, options_.moge_metric, options_.split,
                                   options_.format_options};
    datasets.push_back(open_eval_dataset({root, options_.format, location}));
  }
  const Predictor predictor = make_predictor(options_);
  result.predictor = predictor.name;
  result.run = score_datasets(predictor, datasets, run);
  result.table = write_run_files(options_.output_dir, result.run);
  return result;
}

}  // namespace omnipoint::eval
