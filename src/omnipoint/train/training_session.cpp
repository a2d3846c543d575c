#include "omnipoint/train/training_session.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/train/checkpoint.h"
#include "omnipoint/train/curves.h"
#include "omnipoint/train/distributed.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// log.jsonl's records; a line that is not JSON (a kill mid-line leaves one) is left out.
std::vector<json> read_log(const std::string& path) {
  std::vector<json> records;
  std::istringstream lines(io::read_file(path));
  for (std::string line; std::getline(lines, line);) {
    json record = json::parse(line, nullptr, false);
    if (!record.is_discarded()) records.push_back(std::move(record));
  }
  return records;
}

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

void append_line(const std::string& path, const json& record) {
  std::ofstream out(path, std::ios::app);
  out << record.dump() << "\n";
  if (!out.flush()) throw std::runtime_error("log " + path + ": cannot append to it");
}

// curves.png beside the log (curves.h); a build without image I/O draws none.
void write_curves(const std::string& log_path, const std::string& png_path) {
  if (!io::image_io_available() || !fs::exists(log_path)) return;
  const std::vector<json> records = read_log(log_path);
  if (records.empty()) return;
  io::write_image_png(png_path, render_training_curves(records));
}

json step_log_record(const StepRecord& record, double images_per_second) {
  return {{"step", record.step},
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
          {"images_per_s", images_per_second}};
}

TrainingObserver& silent_observer() {
  static TrainingObserver observer;
  return observer;
}

}  // namespace

TrainingObserver::~TrainingObserver() = default;
void TrainingObserver::progress(const TrainingProgress& /*progress*/) {}
void TrainingObserver::warning(const std::string& /*text*/) {}
void TrainingObserver::finished(const std::string& /*model_path*/) {}

void TrainingSessionOptions::Check() const {
  const auto require = [](bool ok, const std::string& field, const std::string& what) {
    if (!ok) throw std::invalid_argument("training session: " + field + " " + what);
  };
  require(stop_after >= 0, "stop_after", "must be >= 0 (0: to the end)");
  require(!config.output_dir.empty(), "config.output_dir", "must name a folder");
  require(!config.stages.empty() && config.total_steps() > 0, "config.stages",
          "must hold at least one step");
  require(!config.datasets.empty(), "config.datasets", "must hold at least one source");
  require(config.threads >= 1, "config.threads", "must be at least 1");
  require(config.log_every >= 1, "config.log_every", "must be at least 1");
  require(config.checkpoint_every >= 0 && config.eval_every >= 0,
          "config.checkpoint_every/eval_every", "must be >= 0 (0: never)");
}

// The files of the run; only rank 0 (`writer`) writes them.
struct TrainingSession::Outputs {
  bool writer = false;
  std::string checkpoints, log, curves, model, model_ema;

  Outputs(const std::string& output_dir, bool is_main) : writer(is_main) {
    const fs::path dir(output_dir);
    checkpoints = (dir / "checkpoints").string();
    log = (dir / "log.jsonl").string();
    curves = (dir / "curves.png").string();
    model = (dir / "model.safetensors").string();
    model_ema = (dir / "model_ema.safetensors").string();
  }
};

TrainingSession::TrainingSession(TrainingSessionOptions options, TrainingObserver* observer)
    : options_(std::move(options)), observer_(observer ? observer : &silent_observer()) {}

void TrainingSession::Run() {
  options_.Check();
  const TrainConfig& config = options_.config;
  // The config's threads (default 1: a deterministic step, and the ranks of a data-parallel
  // job each on their own cores), from loading the network on.
  util::set_threads(config.threads);
  const bool resume = !options_.resume.empty();
  TrainState resumed;
  if (resume) resumed = read_checkpoint(options_.resume);
  model::OmniPointModel network =
      resume ? model::load_omnipoint_model(resumed.model, resumed.model_metadata)
             : build_model(config);
  // RANK, WORLD_SIZE, ... from a launcher (docs/TRAINING.md); a single process without them.
  // NCCL between GPUs where the config trains on them, Gloo otherwise.
  DistributedOptions distributed_options;
  distributed_options.cuda = config.device == TrainDevice::kCuda;
  const DistributedContext distributed = DistributedContext::from_environment(distributed_options);
  Trainer trainer(config, network, distributed);
  if (resume) trainer.restore(resumed);

  const Outputs outputs(config.output_dir, distributed.is_main());
  if (outputs.writer) {
    fs::create_directories(outputs.checkpoints);
    if (resume)
      truncate_log(outputs.log, trainer.step());
    else if (fs::exists(outputs.log))
      fs::remove(outputs.log);
  }
  train(trainer, outputs);
  report_data_warnings(trainer);
  const std::map<std::string, int64_t> skipped = trainer.batch_source().skipped_samples();
  if (!skipped.empty()) {
    std::string counts;
    for (const auto& [reason, count] : skipped)
      counts += (counts.empty() ? "" : "; ") + std::to_string(count) + "x " + reason;
    observer_->warning("bad samples were met and skipped: " + counts);
  }
  if (!outputs.writer || !trainer.done()) return;
  const auto metadata = model::omnipoint_metadata(network->config());
  io::write_safetensors(outputs.model, trainer.state().model, metadata);
  io::write_safetensors(outputs.model_ema, trainer.ema(), metadata);
  observer_->finished(outputs.model);
}

void TrainingSession::train(Trainer& trainer, const Outputs& outputs) {
  const TrainConfig& config = options_.config;
  const model::OmniPointConfig& network_config = trainer.model()->config();
  const int64_t total = config.total_steps();
  const int64_t end = options_.stop_after > 0 ? std::min(total, options_.stop_after) : total;
  const auto start = std::chrono::steady_clock::now();
  const int64_t first = trainer.step();
  int64_t images = 0;
  bool saved = false;
  const auto evaluate = [&] {
    const std::map<std::string, double> evaluation =
        trainer.evaluate();  // a collective: on every rank
    if (outputs.writer) append_line(outputs.log, {{"step", trainer.step()}, {"eval", evaluation}});
  };
  if (config.eval_at_start && first == 0) evaluate();  // the starting weights, before any step
  while (trainer.step() < end) {
    const StepRecord record = trainer.train_step();
    images += record.images;
    report_data_warnings(trainer);
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    TrainingProgress progress{record, total, images / std::max(elapsed, 1e-9),
                              elapsed / static_cast<double>(record.step - first) *
                                  static_cast<double>(total - record.step)};
    saved = false;
    if (outputs.writer) {
      append_line(outputs.log, step_log_record(record, progress.images_per_second));
      if (record.skipped)
        observer_->warning("step " + std::to_string(record.step) +
                           " skipped: non-finite loss or gradients");
      if (record.step % config.log_every == 0 || record.step == end) observer_->progress(progress);
      if (config.checkpoint_every > 0 && record.step % config.checkpoint_every == 0) {
        write_checkpoint(outputs.checkpoints, trainer.state(), network_config);
        write_curves(outputs.log, outputs.curves);
        saved = true;
      }
    }
    if (config.eval_every > 0 && record.step % config.eval_every == 0) evaluate();
  }
  if (!outputs.writer) return;
  if (!saved) write_checkpoint(outputs.checkpoints, trainer.state(), network_config);
  write_curves(outputs.log, outputs.curves);
}

void TrainingSession::report_data_warnings(Trainer& trainer) {
  for (const std::string& text : trainer.batch_source().take_warnings()) observer_->warning(text);
}

void redraw_training_curves(const std::string& output_dir) {
  const std::string log = (fs::path(output_dir) / "log.jsonl").string();
  if (!fs::exists(log)) throw std::runtime_error("training curves: " + log + " does not exist");
  if (!io::image_io_available())
    throw std::runtime_error("training curves: this build has no image file I/O (OpenCV)");
  write_curves(log, (fs::path(output_dir) / "curves.png").string());
}

}  // namespace omnipoint::train
