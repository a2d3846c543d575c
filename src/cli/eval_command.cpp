// omnipoint eval: binds the options of an eval::EvalJob (omnipoint/eval/eval_job.h), which runs
// a model (OmniPoint or MoGe-2 checkpoint), a folder of external point maps, or a reference
// baseline over datasets (--data, in any format with --format) or a benchmark suite's sets
// (--suite, --root) with MoGe's protocol, per camera split and condition mode. Writes to --out:
//   samples.jsonl   one JSON object per sample × mode (or per skipped sample)
//   summary.json    averages per split and mode, NaN entries excluded and counted (--data)
//   table.md        the paper-style table (--suite: per group and per set)
//   table.json      --suite: the same tables as JSON, with each set's summary
//   points/         with --save-points: each sample × mode's scored point map (and sparse input)
// and a progress line with the ETA on stderr; with --suite, a warning line per set not found.
// With --sequence PREDICTIONS --truth PATH it scores the temporal stability of a predicted
// sequence instead (eval/temporal.h; a rig's video per camera against synth --rig --path's
// set) and prints it (--out: also OUT/temporal.json).
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/dataset_options.h"
#include "cli/device.h"
#include "cli/download_report.h"
#include "cli/eval_rig.h"
#include "cli/threads.h"
#include "omnipoint/eval/eval_job.h"
#include "omnipoint/eval/temporal.h"
#include "omnipoint/io/atomic_file.h"

namespace omnipoint::cli {
namespace {

struct EvalCommandOptions {
  eval::EvalJobOptions job;
  std::string device = "cpu";
  std::string precision = "auto";
  std::vector<std::string> sparse_depth;    // no value: the default count
  std::vector<std::string> format_options;  // --option NAME=VALUE
  bool moge_relative = false;               // MoGe benchmark depth is not metric
  int threads = 0;                          // 0: every core
  std::string sequence;                     // --sequence: a predicted sequence's folder
  std::string truth;                        // --truth: its camera path (synth --path)
};

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

// A progress line with the ETA on stderr.
class EvalProgress : public eval::EvalJobObserver {
 public:
  void progress(int64_t done, int64_t total, double seconds) override {
    const double eta = done > 0 ? seconds / done * (total - done) : 0.0;
    std::fprintf(stderr, "\reval: %lld/%lld samples (%.0f%%), %.1f s elapsed, ETA %.0f s   ",
                 static_cast<long long>(done), static_cast<long long>(total), 100.0 * done / total,
                 seconds, eta);
    if (done == total) std::fputc('\n', stderr);
    std::fflush(stderr);
  }
};

// Runs the benchmark of the bound options; `sparse_depth_given`: --sparse-depth was on the
// command line (with or without a count).
void run_eval(EvalCommandOptions options, bool sparse_depth_given) {
  use_threads(options.threads);
  if (options.device != "cpu" && options.device != "cuda")
    throw std::invalid_argument("--device " + options.device + ": expected cpu or cuda");
  eval::EvalJobOptions& job = options.job;
  job.device = parse_device(options.device);
  job.precision = parse_precision(options.precision, job.device);
  if (!job.model.empty()) {  // a hub reference is fetched; the row keeps the name given
    const std::string path = resolve_model(job.model);
    if (job.label.empty()) job.label = std::filesystem::path(job.model).stem().string();
    job.model = path;
  }
  job.sparse_depth = sparse_depth_given;
  job.sparse_depth_points = sparse_depth_points(options.sparse_depth);
  job.moge_metric = !options.moge_relative;
  parse_format_options(options.format_options, job.format_options);
  if (!job.suite.empty() && job.output_dir.empty())  // beside the working folder, by suite
    job.output_dir = "eval_" + std::filesystem::path(job.suite).stem().string();
  EvalProgress progress;
  const eval::EvalJobResult result = eval::EvalJob(job, &progress).Run();
  std::vector<const eval::Summary*> summaries{&result.run.summary};
  if (result.suite) {
    summaries.clear();
    for (const eval::SuiteSet& set : result.suite->missing)
      std::cerr << "eval: warning: suite set " << set.name << " not found ("
                << (std::filesystem::path(job.suite_root) / set.root).string() << ")\n";
    for (const eval::SuiteSetScores& set : result.suite->sets) summaries.push_back(&set.summary);
  }
  for (const eval::Summary* summary : summaries) {
    const std::string where = result.suite ? " of " + summary->datasets.front() : "";
    for (const auto& [reason, count] : summary->skipped)
      std::cerr << "eval: skipped " << count << " sample(s)" << where << ": " << reason
                << " (details in samples.jsonl)\n";
    for (const auto& mode : summary->modes_not_supported)
      std::cerr << "eval: mode " << mode << " not run" << where << ": " << result.predictor
                << " takes no such input\n";
  }
  std::cout << result.table;
}

// Prints a sequence's frame pairs (each line after `prefix`) and returns them as JSON.
nlohmann::json print_pairs(const eval::TemporalStability& stability, const std::string& prefix) {
  nlohmann::json pairs = nlohmann::json::array();  // NaN (a pair without overlap) is null
  for (size_t t = 0; t < stability.pairs.size(); ++t) {
    const eval::PairStability& pair = stability.pairs[t];
    std::printf("%sframes %zu -> %zu: median relative change %.6f over %lld pixels\n",
                prefix.c_str(), t, t + 1, pair.error, static_cast<long long>(pair.pixels));
    pairs.push_back(nlohmann::json{{"error", pair.error}, {"pixels", pair.pixels}});
  }
  return pairs;
}

// --sequence with a rig's truth (synth --rig --path): each camera's stability, and their mean.
nlohmann::json run_rig_sequence_eval(const EvalCommandOptions& options) {
  const eval::RigTemporalStability stability =
      eval::score_predicted_rig_sequence(options.sequence, options.truth);
  nlohmann::json cameras = nlohmann::json::object();
  for (const auto& [name, camera] : stability.cameras) {
    const nlohmann::json pairs = print_pairs(camera, "camera " + name + ": ");
    std::printf("camera %s: temporal stability %.6f\n", name.c_str(), camera.error);
    cameras[name] = {{"temporal_stability", camera.error}, {"pairs", pairs}};
  }
  std::printf("temporal stability %s: %.6f (mean over %zu cameras)\n", options.sequence.c_str(),
              stability.error, stability.cameras.size());
  return {{"temporal_stability", stability.error}, {"cameras", cameras}};
}

// --sequence: the temporal stability of a predicted sequence against its camera path (or a
// rig's video against its rendered rig path).
void run_sequence_eval(const EvalCommandOptions& options) {
  if (options.truth.empty())
    throw std::invalid_argument(
        "--sequence needs --truth (the camera path of `synth --path`, or the set of `synth --rig "
        "--path`)");
  nlohmann::json report;
  if (eval::is_rig_truth(options.truth)) {
    report = run_rig_sequence_eval(options);
  } else {
    const eval::TemporalStability stability =
        eval::score_predicted_sequence(options.sequence, options.truth);
    const nlohmann::json pairs = print_pairs(stability, "");
    std::printf("temporal stability %s: %.6f (mean over %zu frame pairs)\n",
                options.sequence.c_str(), stability.error, stability.pairs.size());
    report = {{"temporal_stability", stability.error}, {"pairs", pairs}};
  }
  if (!options.job.output_dir.empty()) {
    std::filesystem::create_directories(options.job.output_dir);
    const std::string text = report.dump(2) + "\n";
    io::write_file_atomically(
        (std::filesystem::path(options.job.output_dir) / "temporal.json").string(),
        [&](std::ostream& out) { out << text; });
  }
}

// What is scored (one of --model, --random-model, --predictions, --baseline) and how it is
// labelled.
void add_predictor_options(CLI::App* cmd, EvalCommandOptions& options) {
  cmd->add_option("--model", options.job.model,
                  "OmniPoint or MoGe-2 checkpoint (.safetensors or PyTorch .pt), or a published "
                  "one: hf:OWNER/REPO[/FILE][@REVISION] or a short name (omnipoint models)");
  cmd->add_option(
      "--random-model", options.job.random_model,
      "an OmniPoint config (JSON) with random weights seeded by --seed: the untrained baseline");
  cmd->add_option("--predictions", options.job.predictions,
                  "folder of external predictions: <id>.npy (H, W, 3) metric points per sample");
  cmd->add_option("--baseline", options.job.baseline,
                  "oracle (GT rays and distances) | constant (GT rays, --constant-distance) | "
                  "median (GT rays, the per-pixel median distance of --baseline-data's samples "
                  "of the same camera: picture-blind)");
  cmd->add_option("--baseline-data", options.job.baseline_data,
                  "for --baseline median: training sample folders (e.g. the benchmark's main set)")
      ->expected(1, -1);
  cmd->add_option("--constant-distance", options.job.constant_distance,
                  "metres, for --baseline constant")
      ->capture_default_str();
  cmd->add_option("--label", options.job.label,
                  "row label in the table (default: the file or folder name)");
  cmd->add_option("--num-tokens", options.job.num_tokens,
                  "ViT tokens per image (0: the image's native count)")
      ->capture_default_str();
  cmd->add_option("--device", options.device, "cpu | cuda")->capture_default_str();
  cmd->add_option("--precision", options.precision, kPrecisionHelp)->capture_default_str();
}

// On what (datasets, modes) and what is written.
void add_benchmark_options(CLI::App* cmd, EvalCommandOptions& options) {
  cmd->add_option("--data", options.job.data,
                  "dataset roots: sample folders or MoGe benchmark roots, or with --format "
                  "any format's roots")
      ->expected(1, -1);
  cmd->add_option("--format", options.job.format,
                  "the --data roots' format (`omnipoint data formats`: kitti360, stanford2d3d, "
                  "moge, ...); default: sample folders or MoGe benchmarks, found by their files");
  cmd->add_option("--split", options.job.split,
                  "with --format: one of the format's named splits, or a split list file");
  cmd->add_option("--option", options.format_options,
                  "with --format: a format option NAME=VALUE (repeatable)");
  cmd->add_option("--suite", options.job.suite,
                  "a benchmark suite (JSON, e.g. benchmarks/paper_suite.json): scores each of its "
                  "sets found under --root and writes the table per camera group and per set");
  cmd->add_option("--root", options.job.suite_root,
                  "with --suite: the data root its sets' folders are relative to");
  cmd->add_flag("--intrinsics", options.job.intrinsics,
                "also evaluate with the GT camera given (+K, +K+D)");
  cmd->add_option("--sparse-depth", options.sparse_depth,
                  "also evaluate with N GT sparse distances (+D, +K+D); N defaults to 1000")
      ->expected(0, 1);
  cmd->add_option("--out", options.job.output_dir,
                  "output folder (with --suite, default eval_<suite file name>)");
  cmd->add_option("--seed", options.job.seed,
                  "seed mixed into the sparse-depth sampling (and of --random-model's weights)")
      ->capture_default_str();
  cmd->add_flag("--save-points", options.job.save_points,
                "also write OUT/points/<dataset>/<id>/<mode>/points.npy, the point map scored, "
                "and sparse_distance.npy, the sparse radial distances given (+D)");
  cmd->add_flag("--moge-relative", options.moge_relative,
                "--data: MoGe benchmark depth is not metric (a suite says per set)");
}

// --sequence and --truth: temporal stability instead of a benchmark.
void add_sequence_eval_options(CLI::App* cmd, EvalCommandOptions& options) {
  CLI::Option* sequence = cmd->add_option(
      "--sequence", options.sequence,
      "score the temporal stability of a predicted sequence (the --out of predict --sequence) "
      "against --truth: the mean over consecutive frames of the median relative change of a "
      "static point's distance (docs/EVALUATION.md); a rig's video (predict --rig --sequence) "
      "per camera against synth --rig --path's set, and their mean (docs/RIG.md)");
  cmd->add_option("--truth", options.truth,
                  "--sequence: the camera path it was predicted from (synth --path's OUT, or "
                  "synth --rig --path's for a rig's video); --rig: "
                  "TRUTH/<frame>/<camera>/distance.npy (default FRAMES/../truth)");
  for (const char* other :
       {"--model", "--random-model", "--predictions", "--baseline", "--data", "--suite"})
    sequence->excludes(other);
}

}  // namespace

void add_eval_command(CLI::App& app) {
  auto options = std::make_shared<EvalCommandOptions>();
  auto* cmd = app.add_subcommand(
      "eval",
      "Score a model, external point maps or a baseline on datasets (our sample folders, MoGe "
      "benchmarks, any dataset format) or a benchmark suite with MoGe's protocol per camera "
      "split (S.FoV / L.FoV / 360°) and condition mode; writes samples.jsonl and the tables "
      "to --out");
  add_predictor_options(cmd, *options);
  add_benchmark_options(cmd, *options);
  auto rig = std::make_shared<RigEvalArgs>();
  add_rig_eval_options(cmd, *rig);
  add_sequence_eval_options(cmd, *options);
  add_threads_option(cmd, &options->threads);
  auto* sparse = cmd->get_option("--sparse-depth");
  cmd->callback([options, sparse, rig] {
    if (!options->sequence.empty()) {
      run_sequence_eval(*options);
      return;
    }
    if (!rig->rig.empty()) {
      rig->truth = options->truth;
      use_threads(options->threads);
      const eval::EvalJobOptions& job = options->job;
      run_rig_eval(*rig,
                   {job.model, options->device, options->precision, job.output_dir, job.num_tokens,
                    !job.data.empty() || !job.suite.empty() || !job.predictions.empty() ||
                        !job.baseline.empty() || !job.random_model.empty()});
      return;
    }
    if (!options->truth.empty())
      throw std::invalid_argument("--truth goes with --sequence or --rig");
    run_eval(*options, sparse->count() > 0);
  });
}

}  // namespace omnipoint::cli
