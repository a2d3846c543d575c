// omnipoint train: binds the options of a training session (omnipoint/train/training_session.h)
// and prints its progress; --nproc starts the ranks of a data-parallel job on this machine.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/download_report.h"
#include "cli/progress.h"
#include "cli/threads.h"
#include "omnipoint/train/launcher.h"
#include "omnipoint/train/training_session.h"

namespace omnipoint::cli {
namespace {

struct TrainOptions {
  std::string config_path;
  std::vector<std::string> overrides;  // --set key.path=value
  std::string resume;
  int64_t stop_after = 0;  // 0: run to the end
  int64_t nproc = 1;       // > 1: launch that many local ranks
  bool curves_only = false;
};

// The session's reports as "train: ..." lines on stderr.
class PrintingObserver : public train::TrainingObserver {
 public:
  void progress(const train::TrainingProgress& progress) override {
    std::fprintf(stderr, "train: step %lld/%lld (stage %d) loss %.5g  %.2f img/s  ETA %s\n",
                 static_cast<long long>(progress.record.step),
                 static_cast<long long>(progress.total_steps), progress.record.stage,
                 progress.record.loss, progress.images_per_second,
                 clock_time(progress.seconds_left).c_str());
  }
  void warning(const std::string& text) override {
    std::fprintf(stderr, "train: %s\n", text.c_str());
  }
  void finished(const std::string& model_path) override {
    std::fprintf(stderr, "train: done; weights in %s\n", model_path.c_str());
  }
};

void run_train(const TrainOptions& options) {
  train::TrainingSessionOptions session;
  session.config = train::TrainConfig::load(options.config_path, options.overrides);
  if (options.curves_only) return train::redraw_training_curves(session.config.output_dir);
  // init.path may name a published checkpoint (hf:..., a short name): the trainer reads the
  // cached file. Ranks of one job fetch it under the cache's lock, one after the other.
  session.config.init_path = resolve_model(session.config.init_path);
  session.resume = options.resume;
  session.stop_after = options.stop_after;
  session.Check();
  // The session computes on the config's threads, its OpenMP workers waiting passively
  // (cli/threads.h).
  use_threads(session.config.threads);
  PrintingObserver observer;
  train::TrainingSession(std::move(session), &observer).Run();
}

// --nproc N: N copies of this command as the ranks of one data-parallel job on this machine,
// as torchrun would start them.
void launch_ranks(const TrainOptions& options) {
  std::vector<std::string> arguments{"train", "--config", options.config_path};
  for (const std::string& assignment : options.overrides)
    arguments.insert(arguments.end(), {"--set", assignment});
  if (!options.resume.empty()) arguments.insert(arguments.end(), {"--resume", options.resume});
  if (options.stop_after > 0)
    arguments.insert(arguments.end(), {"--stop-after", std::to_string(options.stop_after)});
  const int code = train::launch_local(static_cast<int>(options.nproc), arguments);
  if (code != 0)
    throw std::runtime_error("train --nproc " + std::to_string(options.nproc) +
                             ": a rank exited with code " + std::to_string(code));
}

}  // namespace

void add_train_command(CLI::App& app) {
  auto options = std::make_shared<TrainOptions>();
  CLI::App* command = app.add_subcommand(
      "train",
      "Train an OmniPoint model from a JSON config (stages, data, losses, optimiser); "
      "checkpoints and log.jsonl go to the config's output_dir");
  command->add_option("--config", options->config_path, "Training config (.json)")->required();
  command
      ->add_option("--set", options->overrides,
                   "Override a config key, KEY.PATH=VALUE (repeatable; VALUE as JSON, else a "
                   "string), e.g. --set stages[0].steps=2000 --set output_dir=runs/b")
      ->expected(1)
      ->multi_option_policy(CLI::MultiOptionPolicy::TakeAll);
  command->add_option(
      "--resume", options->resume,
      "Continue from a checkpoint: a run's output_dir, its checkpoints/ folder or one step folder");
  command
      ->add_option(
          "--stop-after", options->stop_after,
          "Stop after this many steps in total (with a checkpoint), as an interruption would")
      ->check(CLI::PositiveNumber);
  command->add_flag(
      "--curves-only", options->curves_only,
      "Only redraw the run's curves.png from its log.jsonl (output_dir of the config)");
  command
      ->add_option("--nproc", options->nproc,
                   "Data-parallel ranks to start on this machine (Gloo; the config's batch_size is "
                   "per rank)")
      ->check(CLI::PositiveNumber);
  command->callback([options] {
    // (Not already inside a launched job, whose ranks see WORLD_SIZE.)
    if (options->nproc == 1 || options->curves_only || std::getenv("WORLD_SIZE") != nullptr)
      return run_train(*options);
    launch_ranks(*options);
  });
}

}  // namespace omnipoint::cli
