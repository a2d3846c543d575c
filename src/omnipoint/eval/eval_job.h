#pragma once
// Scoring one predictor on datasets into one output folder (`omnipoint eval`): an EvalJob
// makes the predictor its options name (a checkpoint, a config with random weights, a folder of
// external point maps, or a reference baseline: predictors.h), runs the benchmark
// (runner.h) in the modes asked for and writes the run's files: samples.jsonl, summary.json,
// table.md and, with save_points, each sample × mode's scored point map.
//
//   omnipoint::eval::EvalJobOptions options;
//   options.model = "model.safetensors";
//   options.data = {"benchmark/final"};  // or: options.suite = "benchmarks/paper_suite.json",
//                                        //     options.suite_root = "data/eval"
//   options.intrinsics = true;
//   options.output_dir = "scores";
//   const omnipoint::eval::EvalJobResult result = omnipoint::eval::EvalJob(options).Run();
//
// Bad options, an unreadable model and datasets without samples are thrown by Run() before any
// sample is scored, and so are a suite's sets that are there but do not open (those not there are
// listed in SuiteResult::missing); a sample that cannot be read or has no prediction is skipped and counted
// (Summary::skipped). Messages name the options by their `omnipoint eval` flags.
#include <c10/core/Device.h>

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "omnipoint/eval/runner.h"
#include "omnipoint/eval/suite.h"
#include "omnipoint/model/precision.h"

namespace omnipoint::eval {

struct EvalJobOptions {
  // What is scored: exactly one of model, random_model, predictions and baseline.
  std::string model;         // a checkpoint (infer::load_network)
  std::string random_model;  // an OmniPoint config (JSON) whose weights are drawn from `seed`
  std::string predictions;   // a folder of <id>.npy (or <dataset>/<id>.npy) metric point maps
  std::string baseline;      // "oracle", "constant" or "median" (predictors.h)
  std::vector<std::string> baseline_data;  // the median baseline's training sample folders
  double constant_distance = 5.0;          // metres, of the constant baseline
  std::string label;  // the table's row; "": the checkpoint's, config's or folder's name
  // The network (model and random_model).
  at::Device device = at::kCPU;                             // where it runs
  model::Precision precision = model::Precision::kFloat32;  // the network's precision
  int64_t num_tokens = 0;  // ViT tokens per image; 0: the model's default
  // The benchmark: datasets (data), or a suite's sets under a data root (suite, suite_root).
  std::vector<std::string> data;  // dataset roots
  // The format of every `data` root (data/dataset.h: a registered format); "": sample folders
  // or MoGe benchmark roots, found by their files.
  std::string format;
  std::string split;                                  // with format: a named split or a list
  std::map<std::string, std::string> format_options;  // with format: the format's options
  std::string suite;                   // a suite file (suite.h); its sets replace `data`
  std::string suite_root;              // the folder the suite's set roots are relative to
  bool intrinsics = false;             // also score with the true camera given (+K, +K+D)
  bool sparse_depth = false;           // also score with sparse true distances given (+D, +K+D)
  int64_t sparse_depth_points = 1000;  // how many (the paper's 1,000)
  uint64_t seed = 0;        // mixed into the sparse-depth sampling; random_model's weights
  bool moge_metric = true;  // MoGe benchmark depth is in metres (data; a suite says per set)
  // Outputs.
  std::string output_dir;    // the run's files (write_run_files; a suite's: write_suite_files)
  bool save_points = false;  // also points/<dataset>/<id>/<mode>/points.npy, sparse_distance.npy

  // std::invalid_argument with one line for an option that is invalid or conflicts with another.
  void Check() const;
};

// What an EvalJob reports while it runs, from the thread that runs it.
class EvalJobObserver {
 public:
  virtual ~EvalJobObserver() = default;
  // After each sample: samples done of `total`, seconds since the first.
  virtual void progress(int64_t /*done*/, int64_t /*total*/, double /*seconds*/) {}
};

struct EvalJobResult {
  std::string predictor;             // the table's row label
  RunResult run;                     // of `data`
  std::optional<SuiteResult> suite;  // of a suite (run is then empty)
  std::string table;                 // table.md's text
};

class EvalJob {
 public:
  // `observer` (may be null) must outlive Run().
  explicit EvalJob(EvalJobOptions options, EvalJobObserver* observer = nullptr);
  // Checks the options, makes the predictor, scores every sample, writes the files.
  EvalJobResult Run();

 private:
  EvalJobOptions options_;
  EvalJobObserver* observer_;
};

}  // namespace omnipoint::eval
