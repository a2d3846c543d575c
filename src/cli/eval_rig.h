#pragma once
// `omnipoint eval --rig RIG.json --frames FRAMES`: rig consistency against ground truth
// (predict::evaluate_rig, omnipoint/predict/rig_eval.h), bound beside eval's dataset options.
#include <CLI/CLI.hpp>

#include <cstdint>
#include <string>

namespace omnipoint::cli {

struct RigEvalArgs {
  std::string rig;     // --rig: the rig file; set: eval scores a rig instead of datasets
  std::string frames;  // --frames: FRAMES/<frame>/<camera>.<ext> [lidar.<ext>]
  std::string truth;   // eval's --truth: TRUTH/<frame>/<camera>/distance.npy ("": FRAMES/../truth)
  bool no_lidar = false;
  int64_t max_size = 0;
};

void add_rig_eval_options(CLI::App* cmd, RigEvalArgs& args);

// eval's predictor options that a rig evaluation shares.
struct RigEvalModel {
  std::string model, device, precision, out;
  int64_t num_tokens = 0;
  bool others_given = false;  // a dataset, suite, baseline or predictions option was given too
};

// Runs the evaluation, prints the table on stdout and the report's path on stderr.
void run_rig_eval(const RigEvalArgs& args, const RigEvalModel& model);

}  // namespace omnipoint::cli
