// omnipoint train: runs the training loop of a JSON config (omnipoint/train/train_config.h),
// writing checkpoints, a JSON-lines log and a progress line; --resume continues a run exactly.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/progress.h"
#include "cli/threads.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/train/checkpoint.h"
#include "omnipoint/train/curves.h"
#include "omnipoint/train/distributed.h"
#include "omnipoint/train/launcher.h"
#include "omnipoint/train/trainer.h"

namespace omnipoint::cli {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

struct TrainOptions {
  std::string config_path;
  std::vector<std::string> overrides;  // --set key.path=value
  std::string resume;
  int64_t stop_after = 0;  // 0: run to the end
  int64_t nproc = 1;       // > 1: launch that many local ranks
  bool curves_only = false;
};

// Keeps the log records of steps <= step (a resumed run rewrites what followed its checkpoint).
void truncate_log(const std::string& path, int64_t step) {
  if (!fs::exists(path)) return;
  std::istringstream lines(io::read_file(path));
  std::string kept, line;
  while (std::getline(lines, line)) {
    if (line.empty()) continue;
    const json record = json::parse(line, nullptr, false);
    if (!record.is_discarded() && record.value("step", int64_t{0}) <= step) kept += line + "\n";
  }
  io::write_file_atomically(path, [&](std::ostream& out) { out << kept; });
}

// curves.png beside the log (train/curves.h); a build without image I/O writes none.
void write_curves(const std::string& log_path, const std::string& png_path) {
  if (!io::image_io_available() || !fs::exists(log_path)) return;
  std::vector<json> records;
  std::istringstream lines(io::read_file(log_path));
  for (std::string line; std::getline(lines, line);) {
    const json record = json::parse(line, nullptr, false);
    if (!record.is_discarded()) records.push_back(record);
  }
  if (records.empty()) return;
  io::write_image_png(png_path, train::render_training_curves(records));
}

void append_line(const std::string& path, const json& record) {
  std::ofstream out(path, std::ios::app);
  out << record.dump() << "\n";
  if (!out.flush()) throw std::runtime_error("log " + path + ": cannot append to it");
}

void run_train(const TrainOptions& options) {
  const train::TrainConfig config =
      train::TrainConfig::load(options.config_path, options.overrides);
  if (options.curves_only) {
    const fs::path out_dir(config.output_dir);
    if (!fs::exists(out_dir / "log.jsonl"))
      throw std::runtime_error("--curves-only: " + (out_dir / "log.jsonl").string() +
                               " does not exist");
    if (!io::image_io_available())
      throw std::runtime_error("--curves-only: this build has no image file I/O (OpenCV)");
    write_curves((out_dir / "log.jsonl").string(), (out_dir / "curves.png").string());
    return;
  }

  // Each rank (or the one process) on the config's threads, OpenBLAS's pool included: the
  // default 1 keeps a step deterministic, and the ranks of --nproc on their own cores.
  use_threads(config.threads);
  train::TrainState resumed;
  const bool resume = !options.resume.empty();
  if (resume) resumed = train::read_checkpoint(options.resume);
  model::OmniPointModel network =
      resume ? model::load_omnipoint_model(resumed.model, resumed.model_metadata)
             : train::build_model(config);
  // RANK, WORLD_SIZE, ... from a launcher (docs/TRAINING.md); a single process without them.
  // NCCL between GPUs where the config trains on them, Gloo otherwise.
  train::DistributedOptions distributed_options;
  distributed_options.cuda = config.device == train::TrainDevice::kCuda;
  const train::DistributedContext distributed =
      train::DistributedContext::from_environment(distributed_options);
  train::Trainer trainer(config, network, distributed);
  if (resume) trainer.restore(resumed);
  const bool writer = distributed.is_main();  // only rank 0 writes logs and files

  const fs::path out_dir(config.output_dir);
  const std::string checkpoint_dir = (out_dir / "checkpoints").string();
  const std::string log_path = (out_dir / "log.jsonl").string();
  const std::string curves_path = (out_dir / "curves.png").string();
  if (writer) {
    fs::create_directories(checkpoint_dir);
    if (resume)
      truncate_log(log_path, trainer.step());
    else if (fs::exists(log_path))
      fs::remove(log_path);
  }

  const int64_t total = config.total_steps();
  const int64_t end = options.stop_after > 0 ? std::min(total, options.stop_after) : total;
  const auto start = std::chrono::steady_clock::now();
  const int64_t first = trainer.step();
  int64_t images = 0;
  bool saved = false;
  while (trainer.step() < end) {
    const train::StepRecord record = trainer.train_step();
    images += record.images;
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const double rate = images / std::max(elapsed, 1e-9);
    const double eta = elapsed / static_cast<double>(record.step - first) *
                       static_cast<double>(total - record.step);
    saved = false;
    if (writer) {
      append_line(log_path, {{"step", record.step},
                             {"stage", record.stage},
                             {"loss", record.loss},
                             {"terms", record.terms},
                             {"grad_norm", record.grad_norm},
                             {"skipped", record.skipped},
                             {"lr_backbone", record.lr_backbone},
                             {"lr_heads", record.lr_heads},
                             {"num_tokens", record.num_tokens},
                             {"image_size", {record.width, record.height}},
                             {"seconds", record.seconds},
                             {"images_per_s", rate}});
      if (record.skipped)
        std::fprintf(stderr, "train: step %lld skipped: non-finite loss or gradients\n",
                     static_cast<long long>(record.step));
      if (record.step % config.log_every == 0 || record.step == end)
        std::fprintf(stderr, "train: step %lld/%lld (stage %d) loss %.5g  %.2f img/s  ETA %s\n",
                     static_cast<long long>(record.step), static_cast<long long>(total),
                     record.stage, record.loss, rate, clock_time(eta).c_str());
      if (config.checkpoint_every > 0 && record.step % config.checkpoint_every == 0) {
        train::write_checkpoint(checkpoint_dir, trainer.state(), network->config());
        write_curves(log_path, curves_path);
        saved = true;
      }
    }
    if (config.eval_every > 0 && record.step % config.eval_every == 0) {
      const std::map<std::string, double> evaluation =
          trainer.evaluate();  // a collective: on every rank
      if (writer) append_line(log_path, {{"step", record.step}, {"eval", evaluation}});
    }
  }
  if (!writer) return;
  if (!saved) train::write_checkpoint(checkpoint_dir, trainer.state(), network->config());
  write_curves(log_path, curves_path);
  if (trainer.done()) {
    const auto metadata = model::omnipoint_metadata(network->config());
    io::write_safetensors((out_dir / "model.safetensors").string(), trainer.state().model,
                          metadata);
    io::write_safetensors((out_dir / "model_ema.safetensors").string(), trainer.ema(), metadata);
    std::fprintf(stderr, "train: done; weights in %s\n",
                 (out_dir / "model.safetensors").string().c_str());
  }
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
    // --nproc N (not already inside a launched job): N copies of this command as the ranks of
    // one data-parallel job on this machine, as torchrun would start them.
    if (options->nproc == 1 || options->curves_only || std::getenv("WORLD_SIZE") != nullptr)
      return run_train(*options);
    std::vector<std::string> arguments{"train", "--config", options->config_path};
    for (const std::string& assignment : options->overrides)
      arguments.insert(arguments.end(), {"--set", assignment});
    if (!options->resume.empty()) arguments.insert(arguments.end(), {"--resume", options->resume});
    if (options->stop_after > 0)
      arguments.insert(arguments.end(), {"--stop-after", std::to_string(options->stop_after)});
    const int code = train::launch_local(static_cast<int>(options->nproc), arguments);
    if (code != 0)
      throw std::runtime_error("train --nproc " + std::to_string(options->nproc) +
                               ": a rank exited with code " + std::to_string(code));
  });
}

}  // namespace omnipoint::cli
