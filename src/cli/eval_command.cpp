// omnipoint eval: runs a model (OmniPoint or MoGe-2 checkpoint), a folder of external point
// maps, or a reference baseline over datasets with MoGe's protocol, per camera split and
// condition mode (omnipoint/eval/runner.h). Writes to --out:
//   samples.jsonl   one JSON object per sample × mode (or per skipped sample)
//   summary.json    averages per split and mode, NaN entries excluded and counted
//   table.md        the paper-style table
//   points/         with --save-points: each sample × mode's scored point map (and sparse input)
// and a progress line with the ETA on stderr.
#include <ATen/ATen.h>
#include <CLI/CLI.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/device.h"
#include "cli/download_report.h"
#include "cli/threads.h"
#include "omnipoint/eval/predictors.h"
#include "omnipoint/eval/runner.h"
#include "omnipoint/infer/infer.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/model/omnipoint_config.h"

namespace omnipoint::cli {
namespace {
namespace fs = std::filesystem;

struct EvalOptions {
  std::string model, random_model, predictions, baseline, out, label, device = "cpu";
  std::string precision = "auto";
  std::vector<std::string> data, baseline_data;
  bool intrinsics = false, moge_relative = false, save_points = false;
  std::vector<std::string> sparse_depth;  // no value: the default count
  int64_t num_tokens = 0;
  uint64_t seed = 0;
  double constant_distance = 5.0;
  int threads = 0;  // 0: every core
};

eval::Predictor model_predictor(const EvalOptions& options) {
  const std::string name =
      options.label.empty() ? fs::path(options.model).stem().string() : options.label;
  const at::Device device = parse_device(options.device);
  return eval::network_predictor(infer::load_network(resolve_model(options.model), device), name,
                                 options.num_tokens, parse_precision(options.precision, device));
}

// DIR/<id>.npy, else DIR/<dataset folder name>/<id>.npy: (H, W, 3) metric points.
eval::Predictor external_predictor(const EvalOptions& options) {
  if (!fs::is_directory(options.predictions))
    throw std::runtime_error("--predictions " + options.predictions + ": not a folder");
  const fs::path root(options.predictions);
  const std::string name = options.label.empty() ? root.filename().string() : options.label;
  return eval::point_map_predictor(name, [root](const eval::EvalSample& item) {
    fs::path path = root / (item.id + ".npy");
    if (!fs::exists(path)) path = root / fs::path(item.dataset).filename() / (item.id + ".npy");
    if (!fs::exists(path))
      throw eval::MissingPrediction("no prediction " + (root / (item.id + ".npy")).string());
    at::Tensor points = io::read_npy(path.string());
    if (points.dim() != 3 || points.size(2) != 3 || !at::isFloatingType(points.scalar_type()))
      throw std::invalid_argument(path.string() + ": expected a float (H, W, 3) point map");
    return points;
  });
}

// An untrained OmniPoint model of a config file, initialised from --seed: the chance-level row
// until trained weights exist.
eval::Predictor random_model_predictor(const EvalOptions& options) {
  const auto config = model::OmniPointConfig::from_json_text(io::read_file(options.random_model));
  at::manual_seed(options.seed);
  const std::string name =
      options.label.empty() ? fs::path(options.random_model).stem().string() + " (random weights)"
                            : options.label;
  const at::Device device = parse_device(options.device);
  return eval::network_predictor(infer::Network(model::OmniPointModel(config), device), name,
                                 options.num_tokens, parse_precision(options.precision, device));
}

eval::Predictor make_predictor(const EvalOptions& options) {
  const int given = !options.model.empty() + !options.random_model.empty() +
                    !options.predictions.empty() + !options.baseline.empty();
  if (given != 1)
    throw std::invalid_argument(
        "give exactly one of --model, --random-model, --predictions, --baseline");
  if (options.baseline != "median" && !options.baseline_data.empty())
    throw std::invalid_argument("--baseline-data is for --baseline median only");
  if (!options.model.empty()) return model_predictor(options);
  if (!options.random_model.empty()) return random_model_predictor(options);
  if (!options.predictions.empty()) return external_predictor(options);
  eval::Predictor predictor;
  if (options.baseline == "oracle") {
    predictor = eval::oracle_predictor();
  } else if (options.baseline == "constant") {
    predictor = eval::constant_distance_predictor(options.constant_distance);
  } else if (options.baseline == "median") {
    if (options.baseline_data.empty())
      throw std::invalid_argument(
          "--baseline median needs --baseline-data: the training samples of the cameras");
    predictor = eval::median_map_predictor(options.baseline_data);
  } else {
    throw std::invalid_argument("--baseline " + options.baseline +
                                ": expected oracle, constant or median");
  }

  if (!options.label.empty()) predictor.name = options.label;
  return predictor;
}

// --sparse-depth takes an optional count (1,000, the paper's, when given without one).
int64_t sparse_depth_points(const std::vector<std::string>& values) {
  if (values.empty() || values.front().empty()) return 1000;
  std::size_t used = 0;
  int64_t count = 0;
  try {
    count = std::stoll(values.front(), &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used != values.front().size() || count < 1)
    throw std::invalid_argument("--sparse-depth " + values.front() + ": expected a count >= 1");
  return count;
}

// OUT/points/<dataset folder>/<id>/<mode>/: the point map scored and the sparse distances given.
void save_points(const fs::path& out, const eval::EvalSample& item, const eval::Mode& mode,
                 const eval::Conditions& conditions, const eval::GeometryPrediction& prediction) {
  fs::path dataset = fs::path(item.dataset).lexically_normal();
  if (dataset.filename().empty()) dataset = dataset.parent_path();
  const fs::path folder = out / "points" / dataset.filename() / item.id / mode.name();
  fs::create_directories(folder);
  io::write_npy((folder / "points.npy").string(), eval::scored_points(prediction));
  if (conditions.sparse_depth.defined())
    io::write_npy((folder / "sparse_distance.npy").string(),
                  conditions.sparse_depth.to(at::kFloat).contiguous());
}

void print_progress(int64_t done, int64_t total, double seconds) {
  const double eta = done > 0 ? seconds / done * (total - done) : 0.0;
  std::fprintf(stderr, "\reval: %lld/%lld samples (%.0f%%), %.1f s elapsed, ETA %.0f s   ",
               static_cast<long long>(done), static_cast<long long>(total), 100.0 * done / total,
               seconds, eta);
  if (done == total) std::fputc('\n', stderr);
  std::fflush(stderr);
}

// Runs the benchmark of the bound options; `sparse_depth_given`: --sparse-depth was on the
// command line (with or without a count).
void run_eval(const EvalOptions& options, bool sparse_depth_given) {
  use_threads(options.threads);
  if (options.device != "cpu" && options.device != "cuda")
    throw std::invalid_argument("--device " + options.device + ": expected cpu or cuda");
  if (options.num_tokens < 0)
    throw std::invalid_argument("--num-tokens " + std::to_string(options.num_tokens) +
                                ": expected >= 0");
  eval::RunOptions run;
  run.sparse_depth_points = sparse_depth_points(options.sparse_depth);
  run.modes = eval::evaluation_modes(options.intrinsics, sparse_depth_given);
  run.seed = options.seed;
  run.moge_metric = !options.moge_relative;
  run.progress = print_progress;
  if (options.save_points)
    run.scored = [out = fs::path(options.out)](const eval::EvalSample& item, const eval::Mode& mode,
                                               const eval::Conditions& conditions,
                                               const eval::GeometryPrediction& prediction) {
      save_points(out, item, mode, conditions, prediction);
    };
  const eval::Predictor predictor = make_predictor(options);
  const eval::RunResult result = eval::run_benchmark(predictor, options.data, run);
  const std::string table = eval::write_run_files(options.out, result);
  for (const auto& [reason, count] : result.summary.skipped)
    std::cerr << "eval: skipped " << count << " sample(s): " << reason
              << " (details in samples.jsonl)\n";
  for (const auto& mode : result.summary.modes_not_supported)
    std::cerr << "eval: mode " << mode << " not run: " << predictor.name
              << " takes no such input\n";
  std::cout << table;
}

// What is scored (one of --model, --random-model, --predictions, --baseline) and how it is
// labelled.
void add_predictor_options(CLI::App* cmd, EvalOptions& options) {
  cmd->add_option("--model", options.model,
                  "OmniPoint or MoGe-2 checkpoint (.safetensors), or a published one: "
                  "hf:OWNER/REPO[/FILE][@REVISION] or a short name (omnipoint models)");
  cmd->add_option(
      "--random-model", options.random_model,
      "an OmniPoint config (JSON) with random weights seeded by --seed: the untrained baseline");
  cmd->add_option("--predictions", options.predictions,
                  "folder of external predictions: <id>.npy (H, W, 3) metric points per sample");
  cmd->add_option("--baseline", options.baseline,
                  "oracle (GT rays and distances) | constant (GT rays, --constant-distance) | "
                  "median (GT rays, the per-pixel median distance of --baseline-data's samples "
                  "of the same camera: picture-blind)");
  cmd->add_option("--baseline-data", options.baseline_data,
                  "for --baseline median: training sample folders (e.g. the benchmark's main set)")
      ->expected(1, -1);
  cmd->add_option("--constant-distance", options.constant_distance,
                  "metres, for --baseline constant")
      ->capture_default_str();
  cmd->add_option("--label", options.label,
                  "row label in the table (default: the file or folder name)");
  cmd->add_option("--num-tokens", options.num_tokens,
                  "ViT tokens per image (0: the image's native count)")
      ->capture_default_str();
  cmd->add_option("--device", options.device, "cpu | cuda")->capture_default_str();
  cmd->add_option("--precision", options.precision, kPrecisionHelp)->capture_default_str();
}

// On what (datasets, modes) and what is written.
void add_benchmark_options(CLI::App* cmd, EvalOptions& options) {
  cmd->add_option("--data", options.data, "dataset folders (sample folders, MoGe benchmark roots)")
      ->required()
      ->expected(1, -1);
  cmd->add_flag("--intrinsics", options.intrinsics,
                "also evaluate with the GT camera given (+K, +K+D)");
  cmd->add_option("--sparse-depth", options.sparse_depth,
                  "also evaluate with N GT sparse distances (+D, +K+D); N defaults to 1000")
      ->expected(0, 1);
  cmd->add_option("--out", options.out, "output folder")->required();
  cmd->add_option("--seed", options.seed,
                  "seed mixed into the sparse-depth sampling (and of --random-model's weights)")
      ->capture_default_str();
  cmd->add_flag("--save-points", options.save_points,
                "also write OUT/points/<dataset>/<id>/<mode>/points.npy, the point map scored, "
                "and sparse_distance.npy, the sparse radial distances given (+D)");
  cmd->add_flag("--moge-relative", options.moge_relative, "MoGe benchmark depth is not metric");
}

}  // namespace

void add_eval_command(CLI::App& app) {
  auto options = std::make_shared<EvalOptions>();
  auto* cmd = app.add_subcommand(
      "eval",
      "Score a model, external point maps or a baseline on datasets (our sample folders, MoGe "
      "benchmarks) with MoGe's protocol per camera split (S.FoV / L.FoV / 360°) and condition "
      "mode; writes samples.jsonl, summary.json and table.md to --out");
  add_predictor_options(cmd, *options);
  add_benchmark_options(cmd, *options);
  add_threads_option(cmd, &options->threads);
  auto* sparse = cmd->get_option("--sparse-depth");
  cmd->callback([options, sparse] { run_eval(*options, sparse->count() > 0); });
}

}  // namespace omnipoint::cli
