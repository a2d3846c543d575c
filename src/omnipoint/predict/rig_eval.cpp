#include "omnipoint/predict/rig_eval.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "omnipoint/geometry/alignment.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/point_cloud.h"

namespace omnipoint::predict {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string number(double value, int digits = 4) {
  std::ostringstream text;
  text.precision(digits);
  text << value;
  return text.str();
}

// The frame folders as the job lists them (immediate subfolders, hidden ones left out).
std::vector<fs::path> frame_folders(const std::string& frames_dir) {
  std::vector<fs::path> frames;
  if (!fs::is_directory(frames_dir)) return frames;  // the job says so, one line
  for (const fs::directory_entry& entry : fs::directory_iterator(frames_dir))
    if (entry.is_directory() && entry.path().filename().string().front() != '.')
      frames.push_back(entry.path());
  std::sort(frames.begin(), frames.end());
  return frames;
}

bool has_sweep(const fs::path& frame) {
  for (const fs::directory_entry& entry : fs::directory_iterator(frame))
    if (entry.is_regular_file() && entry.path().stem() == "lidar" &&
        io::is_point_cloud_file(entry.path().string()))
      return true;
  return false;
}

// The truth distances of one camera at the prediction's size (nearest pixel when they differ).
at::Tensor truth_distance(const fs::path& file, int64_t height, int64_t width) {
  if (!fs::is_regular_file(file))
    throw std::invalid_argument(file.string() + ": missing (the camera's ground-truth distances)");
  at::Tensor truth = io::read_npy(file.string()).to(at::kFloat);
  if (truth.dim() != 2)
    throw std::invalid_argument(file.string() + ": expected an (H, W) distance map");
  if (truth.size(0) != height || truth.size(1) != width)
    truth = at::upsample_nearest2d(truth.unsqueeze(0).unsqueeze(0), {height, width})
                .squeeze(0)
                .squeeze(0);
  return truth;
}

double spread_of(const std::vector<double>& ratios) {
  if (ratios.empty()) return 0;
  return *std::max_element(ratios.begin(), ratios.end()) /
             *std::min_element(ratios.begin(), ratios.end()) -
         1.0;
}

// Scores the frames of one rule as the job writes them.
class RuleScorer : public RigPredictJobObserver {
 public:
  RuleScorer(RigEvalRule& rule, fs::path truth_dir)
      : rule_(rule), truth_dir_(std::move(truth_dir)) {}
  void frame_written(const RigFrameResult& frame) override {
    RigEvalFrame scored;
    scored.name = frame.name;
    scored.overlap_residual = frame.overlap_residual;
    std::vector<double> ratios, applied_ratios;
    for (const RigCameraResult& camera : frame.cameras) {
      const Prediction& p = camera.prediction;
      const at::Tensor truth =
          truth_distance(truth_dir_ / frame.name / camera.name / "distance.npy", p.distance.size(0),
                         p.distance.size(1));
      const at::Tensor network = p.distance / camera.applied_scale;
      const at::Tensor valid = p.mask & (truth > 0);
      if (valid.sum().item<int64_t>() == 0)
        throw std::invalid_argument(frame.name + "/" + camera.name +
                                    ": no pixel both predicted and in the truth");
      RigEvalCamera scored_camera;
      scored_camera.name = camera.name;
      scored_camera.scale_source = camera.scale_source;
      scored_camera.scale = camera.scale;
      scored_camera.applied_scale = camera.applied_scale;
      scored_camera.true_scale =
          geometry::fit_scale_to_sparse_depth(network.flatten(), truth.flatten(), valid.flatten())
              .item<double>();
      scored_camera.error = camera.scale / scored_camera.true_scale - 1.0;
      scored_camera.applied_error = camera.applied_scale / scored_camera.true_scale - 1.0;
      ratios.push_back(1.0 + scored_camera.error);
      applied_ratios.push_back(1.0 + scored_camera.applied_error);
      scored.cameras.push_back(scored_camera);
    }
    scored.spread = spread_of(ratios);
    scored.applied_spread = spread_of(applied_ratios);
    rule_.frames.push_back(std::move(scored));
  }
  void frame_failed(const std::string& frame, const std::string& error) override {
    if (failure_.empty()) failure_ = frame + ": " + error;
  }
  const std::string& failure() const { return failure_; }

 private:
  RigEvalRule& rule_;
  fs::path truth_dir_;
  std::string failure_;
};

void summarise(RigEvalRule& rule, const io::Rig& rig) {
  std::vector<double> residuals;
  for (const io::RigCamera& camera : rig.cameras) {
    double sum = 0;
    int64_t count = 0;
    for (const RigEvalFrame& frame : rule.frames)
      for (const RigEvalCamera& scored : frame.cameras)
        if (scored.name == camera.name) {
          sum += std::abs(scored.error);
          ++count;
        }
    rule.camera_names.push_back(camera.name);
    rule.mean_abs_error.push_back(count > 0 ? sum / static_cast<double>(count) : NAN);
  }
  for (const RigEvalFrame& frame : rule.frames) {
    rule.mean_spread += frame.spread / static_cast<double>(rule.frames.size());
    rule.mean_applied_spread += frame.applied_spread / static_cast<double>(rule.frames.size());
    if (frame.overlap_residual) residuals.push_back(*frame.overlap_residual);
  }
  if (!residuals.empty()) {
    double sum = 0;
    for (double r : residuals) sum += r;
    rule.mean_overlap_residual = sum / static_cast<double>(residuals.size());
  }
}

json rule_json(const RigEvalRule& rule) {
  json frames = json::array();
  for (const RigEvalFrame& frame : rule.frames) {
    json cameras = json::object();
    for (const RigEvalCamera& c : frame.cameras)
      cameras[c.name] = {
          {"scale_source", c.scale_source}, {"scale", c.scale}, {"applied_scale", c.applied_scale},
          {"true_scale", c.true_scale},     {"error", c.error}, {"applied_error", c.applied_error}};
    frames.push_back({{"frame", frame.name},
                      {"spread", frame.spread},
                      {"applied_spread", frame.applied_spread},
                      {"overlap_residual",
                       frame.overlap_residual ? json(*frame.overlap_residual) : json(nullptr)},
                      {"cameras", cameras}});
  }
  json mean_abs_error = json::object();
  for (size_t c = 0; c < rule.camera_names.size(); ++c)
    mean_abs_error[rule.camera_names[c]] =
        std::isnan(rule.mean_abs_error[c]) ? json(nullptr) : json(rule.mean_abs_error[c]);
  return {{"rule", rule.name},
          {"mean_abs_error", mean_abs_error},
          {"mean_spread", rule.mean_spread},
          {"mean_applied_spread", rule.mean_applied_spread},
          {"mean_overlap_residual",
           rule.mean_overlap_residual ? json(*rule.mean_overlap_residual) : json(nullptr)},
          {"frames", frames}};
}

std::string percent(double value) {
  return number(100 * value, 3) + " %";
}

std::string markdown_table(const std::vector<RigEvalRule>& rules) {
  if (rules.empty()) return "";
  std::string header = "| rule | frames |", line = "|---|---|";
  for (const std::string& name : rules.front().camera_names) {
    header += " " + name + " \\|scale error\\| |";
    line += "---|";
  }
  header += " spread of scale errors | spread of applied scales | overlap residual |\n";
  line += "---|---|---|\n";
  std::string table = header + line;
  for (const RigEvalRule& rule : rules) {
    table += "| " + rule.name + " | " + std::to_string(rule.frames.size()) + " |";
    for (double error : rule.mean_abs_error)
      table += " " + (std::isnan(error) ? std::string("-") : percent(error)) + " |";
    table += " " + percent(rule.mean_spread) + " | " + percent(rule.mean_applied_spread) + " | " +
             (rule.mean_overlap_residual ? percent(*rule.mean_overlap_residual) : "-") + " |\n";
  }
  return table;
}

}  // namespace

void RigEvalOptions::Check() const {
  job.Check();
  if (job.output_dir.empty()) throw std::invalid_argument("--out: no output folder given");
}

RigEvalResult evaluate_rig(const RigEvalOptions& options) {
  options.Check();
  const io::Rig rig = io::read_rig(options.job.rig);
  const fs::path truth_dir = options.truth_dir.empty()
                                 ? fs::path(options.job.frames_dir).parent_path() / "truth"
                                 : fs::path(options.truth_dir);
  const std::vector<fs::path> frames = frame_folders(options.job.frames_dir);
  bool sweeps = false;
  for (const fs::path& frame : frames) {
    if (!fs::is_directory(truth_dir / frame.filename()))
      throw std::invalid_argument((truth_dir / frame.filename()).string() +
                                  ": missing (the truth of frame " + frame.filename().string() +
                                  "; --truth names the folder)");
    sweeps = sweeps || has_sweep(frame);
  }
  std::vector<std::pair<std::string, std::pair<bool, bool>>> rules;  // name, (lidar, overlap)
  if (options.lidar && sweeps && rig.lidar) rules.push_back({"lidar", {true, true}});
  rules.push_back({"overlap", {false, true}});
  rules.push_back({"independent", {false, false}});

  RigEvalResult result;
  for (const auto& [name, flags] : rules) {
    RigPredictJobOptions job = options.job;
    job.output_dir = (fs::path(options.job.output_dir) / name).string();
    job.output_files = {"distance.npy"};
    job.lidar = flags.first;
    job.overlap = flags.second;
    RigEvalRule rule;
    rule.name = name;
    RuleScorer scorer(rule, truth_dir);
    RigPredictJob(job, &scorer).Run();
    if (!scorer.failure().empty())
      throw std::runtime_error("rule " + name + ": frame " + scorer.failure());
    summarise(rule, rig);
    result.rules.push_back(std::move(rule));
  }
  json report = {{"rig", options.job.rig},
                 {"frames", options.job.frames_dir},
                 {"truth", truth_dir.string()},
                 {"rules", json::array()}};
  for (const RigEvalRule& rule : result.rules) report["rules"].push_back(rule_json(rule));
  result.report_path = (fs::path(options.job.output_dir) / "rig_eval.json").string();
  const std::string text = report.dump(2) + "\n";
  io::write_file_atomically(result.report_path, [&](std::ostream& out) { out << text; });
  result.table = markdown_table(result.rules);
  return result;
}

}  // namespace omnipoint::predict
