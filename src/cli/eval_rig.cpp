#include "cli/eval_rig.h"

#include <iostream>
#include <stdexcept>

#include "cli/bundled.h"
#include "cli/device.h"
#include "omnipoint/predict/rig_eval.h"

namespace omnipoint::cli {

void add_rig_eval_options(CLI::App* cmd, RigEvalArgs& args) {
  cmd->add_option("--rig", args.rig,
                  "score a rig's scales instead of datasets: the rig file of --frames "
                  "(docs/EVALUATION.md, Rigs)");
  cmd->add_option("--frames", args.frames,
                  "--rig: the frames (FRAMES/<frame>/<camera>.png [lidar.bin], as `omnipoint "
                  "synth --rig` writes them)");
  cmd->add_flag("--no-lidar", args.no_lidar,
                "--rig: do not score the LiDAR rule (the sweeps are left out of every rule)");
  cmd->add_option("--max-size", args.max_size,
                  "--rig: longest image side for the network (0: as stored)")
      ->capture_default_str();
}

void run_rig_eval(const RigEvalArgs& args, const RigEvalModel& model) {
  if (model.others_given)
    throw std::invalid_argument(
        "--rig scores a rig's frames: no --data, --suite, --predictions, --baseline or "
        "--random-model with it");
  if (args.frames.empty()) throw std::invalid_argument("--rig needs --frames FRAMES");
  predict::RigEvalOptions options;
  options.job.rig = args.rig;
  options.job.frames_dir = args.frames;
  options.job.device = parse_device(model.device);
  options.job.precision = parse_precision(model.precision, options.job.device);
  options.job.model_path = model_path_or_bundled(model.model);
  options.job.num_tokens = model.num_tokens;
  options.job.max_size = args.max_size;
  options.job.output_dir = model.out.empty() ? "eval_rig" : model.out;
  options.truth_dir = args.truth;
  options.lidar = !args.no_lidar;
  const predict::RigEvalResult result = predict::evaluate_rig(options);
  std::cout << result.table;
  std::cerr << "eval: rig report " << result.report_path << "\n";
}

}  // namespace omnipoint::cli
