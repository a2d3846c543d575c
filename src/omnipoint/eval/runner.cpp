#include "omnipoint/eval/runner.h"

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <optional>
#include <ostream>
#include <stdexcept>

#include "omnipoint/camera/camera_info.h"
#include "omnipoint/data/dataset_index.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/io/atomic_file.h"

namespace omnipoint::eval {

namespace fs = std::filesystem;

const std::array<Split, 3> kSplits{Split::kSmallFov, Split::kLargeFov, Split::kPanorama};

std::string split_name(Split split) {
  switch (split) {
    case Split::kSmallFov:
      return "S.FoV";
    case Split::kLargeFov:
      return "L.FoV";
    case Split::kPanorama:
      return "360°";
  }
  return "";
}

Split camera_split(const camera::Camera& camera) {
  switch (camera::camera_class(camera)) {
    case camera::CameraClass::kPanorama:
      return Split::kPanorama;
    case camera::CameraClass::kWide:
      return Split::kLargeFov;
    case camera::CameraClass::kPerspective:
      break;
  }
  return Split::kSmallFov;
}

std::string Mode::name() const {
  if (intrinsics && sparse_depth) return "+K+D";
  if (intrinsics) return "+K";
  if (sparse_depth) return "+D";
  return "none";
}

std::vector<Mode> evaluation_modes(bool intrinsics, bool sparse_depth) {
  std::vector<Mode> modes{Mode{}};
  if (intrinsics) modes.push_back({true, false});
  if (sparse_depth) modes.push_back({false, true});
  if (intrinsics && sparse_depth) modes.push_back({true, true});
  return modes;
}

uint64_t sample_seed(const std::string& id, uint64_t seed) {
  uint64_t hash = 1469598103934665603ull;  // FNV-1a: stable across platforms and runs
  for (const unsigned char c : id) hash = (hash ^ c) * 1099511628211ull;
  return hash ^ (seed * 0x9E3779B97F4A7C15ull);
}

Conditions make_conditions(const data::Sample& sample, const Mode& mode,
                           int64_t sparse_depth_points, uint64_t seed) {
  Conditions conditions;
  if (mode.intrinsics) conditions.rays = sample.camera.ray_map(at::kFloat).rays;
  if (mode.sparse_depth) {
    auto generator = at::make_generator<at::CPUGeneratorImpl>(seed);
    conditions.sparse_depth =
        geometry::sample_uniform(sample.distance, sample.mask, sparse_depth_points, generator)
            .depth;
  }
  return conditions;
}

at::Tensor scored_points(const GeometryPrediction& prediction) {
  if (prediction.points.defined()) return prediction.points.to(at::kFloat);
  return (prediction.metric_scale * prediction.distance.to(at::kFloat)).unsqueeze(-1) *
         prediction.rays.to(at::kFloat);
}

Metrics score_sample(const data::Sample& sample, Split split,
                     const GeometryPrediction& prediction) {
  const auto height = sample.distance.size(0), width = sample.distance.size(1);
  const auto expect = [&](const at::Tensor& t, const std::vector<int64_t>& shape,
                          const char* what) {
    if (!t.defined() || t.sizes() != at::IntArrayRef(shape))
      throw std::invalid_argument(std::string("prediction ") + what + ": expected shape " +
                                  c10::str(at::IntArrayRef(shape)) + ", got " +
                                  (t.defined() ? c10::str(t.sizes()) : std::string("none")));
  };
  expect(prediction.rays, {height, width, 3}, "rays");
  expect(prediction.distance, {height, width}, "distance");
  if (prediction.points.defined()) expect(prediction.points, {height, width, 3}, "points");

  const auto ray_map = sample.camera.ray_map(at::kFloat);
  GroundTruth gt;
  gt.mask = sample.mask & ray_map.valid;
  gt.points = sample.distance.unsqueeze(-1) * ray_map.rays;
  gt.depth = split == Split::kSmallFov ? gt.points.select(-1, 2) : sample.distance;
  gt.is_metric = sample.metric;

  Prediction pred;
  pred.points = scored_points(prediction);
  pred.depth = split == Split::kSmallFov ? pred.points.select(-1, 2)
                                         : at::linalg_vector_norm(pred.points, 2, {-1});
  pred.is_metric = prediction.is_metric;
  return compute_metrics(pred, gt);
}

namespace {

nlohmann::json number(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

nlohmann::json metrics_json(const Metrics& metrics) {
  nlohmann::json entries = nlohmann::json::object();
  for (const auto& [name, score] : metrics.entries)
    entries[name] = {{"rel", number(score.rel)}, {"delta1", number(score.delta1)}};
  return entries;
}

// An item's id: its name relative to the root when it lies under it (readers that name items
// by their full path), else the name itself (readers whose names are relative already).
std::string relative_id(const std::string& name, const std::string& root) {
  const fs::path relative =
      fs::path(name).lexically_normal().lexically_relative(fs::path(root).lexically_normal());
  if (relative.empty() || *relative.begin() == "..") return fs::path(name).generic_string();
  return relative.generic_string();
}

}  // namespace

EvalDataset open_eval_dataset(const EvalSource& source) {
  EvalDataset dataset{source.name, {}};
  if (source.format.empty()) {
    const bool metric = source.location.metric;
    for (data::DatasetItem& item : data::list_dataset(source.location.path)) {
      std::string id = item.id;
      dataset.items.push_back({std::move(id), [item = std::move(item), metric] {
                                 return data::read_dataset_item(item, metric);
                               }});
    }
    return dataset;
  }
  std::shared_ptr<const data::Dataset> opened = data::open_dataset(source.format, source.location);
  for (int64_t index = 0; index < opened->size(); ++index)
    dataset.items.push_back(
        {relative_id(opened->item_name({index, 0}), source.location.path), [opened, index] {
           return opened->item({index, 0});
         }});
  return dataset;
}

RunResult run_benchmark(const Predictor& predictor, const std::vector<std::string>& datasets,
                        const RunOptions& options) {
  if (datasets.empty()) throw std::invalid_argument("no dataset given");
  std::vector<EvalDataset> opened;
  for (const std::string& root : datasets) {
    data::DatasetLocation location;
    location.path = root;
    location.metric = options.moge_metric;
    opened.push_back(open_eval_dataset({root, "", location}));
  }
  return score_datasets(predictor, opened, options);
}

RunResult score_datasets(const Predictor& predictor, const std::vector<EvalDataset>& datasets,
                         const RunOptions& options) {
  if (datasets.empty()) throw std::invalid_argument("no dataset given");
  if (options.sparse_depth_points < 1)
    throw std::invalid_argument("sparse depth points " +
                                std::to_string(options.sparse_depth_points) + ": expected >= 1");
  std::vector<std::pair<std::string, const EvalItem*>> items;
  for (const EvalDataset& dataset : datasets)
    for (const EvalItem& item : dataset.items) items.emplace_back(dataset.name, &item);
  std::vector<std::string> names;
  names.reserve(datasets.size());
  for (const EvalDataset& dataset : datasets) names.push_back(dataset.name);

  RunResult result;
  Summary& summary = result.summary;
  summary.model = predictor.name;
  summary.datasets = names;
  summary.samples_total = static_cast<int64_t>(items.size());
  std::vector<Mode> modes;
  for (const Mode& mode : options.modes) {
    const bool ok = (!mode.intrinsics || predictor.accepts_intrinsics) &&
                    (!mode.sparse_depth || predictor.accepts_sparse_depth);
    (ok ? summary.modes : summary.modes_not_supported).push_back(mode.name());
    if (ok) modes.push_back(mode);
    if (mode.sparse_depth && ok) summary.sparse_depth_points = options.sparse_depth_points;
  }

  std::map<std::string, std::map<std::string, std::vector<Metrics>>> per_split;
  std::map<std::string, int64_t> split_samples;
  const auto start = std::chrono::steady_clock::now();
  const auto skip = [&](const std::string& dataset, const std::string& id,
                        const std::string& reason, const std::string& error) {
    ++summary.skipped[reason];
    result.records.push_back(nlohmann::json{
        {"dataset", dataset},
        {"id", id},
        {"skipped", reason},
        {"error", error}}.dump());
  };

  for (size_t index = 0; index < items.size(); ++index) {
    const std::string& root = items[index].first;
    const EvalItem& item = *items[index].second;
    std::optional<EvalSample> read;
    try {
      data::Sample sample = item.read();
      const Split split = camera_split(sample.camera);
      read = EvalSample{root, item.id, split, std::move(sample)};
    } catch (const std::exception& e) {
      skip(root, item.id, "unreadable sample", e.what());
    }
    // An unlabelled set (the "images" format's) has nothing to score: refused, not skipped.
    if (read && !read->sample.labelled)
      throw std::runtime_error("dataset " + root + ": sample " + item.id +
                               " has no labels (meta.json \"labelled\": false); evaluation "
                               "needs ground-truth geometry");
    if (read) {
      const EvalSample& sample = *read;
      const std::string split = split_name(sample.split);
      std::vector<std::pair<std::string, Metrics>> scored;
      std::vector<std::string> lines;
      try {
        for (const Mode& mode : modes) {
          const auto t0 = std::chrono::steady_clock::now();
          const Conditions conditions = make_conditions(
              sample.sample, mode, options.sparse_depth_points, sample_seed(item.id, options.seed));
          const GeometryPrediction prediction = predictor.predict(sample, conditions);
          Metrics metrics = score_sample(sample.sample, sample.split, prediction);
          if (options.scored) options.scored(sample, mode, conditions, prediction);
          const double seconds =
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
          lines.push_back(nlohmann::json{{"dataset", root},
                                         {"id", item.id},
                                         {"split", split},
                                         {"mode", mode.name()},
                                         {"camera", sample.sample.camera.model_name()},
                                         {"valid_pixels", metrics.num_valid_pixels},
                                         {"seconds", seconds},
                                         {"entries", metrics_json(metrics)},
                                         {"warnings", metrics.warnings}}
                              .dump());
          scored.emplace_back(mode.name(), std::move(metrics));
        }
      } catch (const MissingPrediction& e) {
        skip(root, item.id, "missing prediction", e.what());
        scored.clear();
      } catch (const std::exception& e) {
        skip(root, item.id, "prediction failed", e.what());
        scored.clear();
      }
      if (!scored.empty()) {
        ++summary.samples_evaluated;
        ++split_samples[split];
        for (auto& line : lines) result.records.push_back(std::move(line));
        for (auto& [mode, metrics] : scored) per_split[split][mode].push_back(std::move(metrics));
      }
    }
    if (options.progress)
      options.progress(
          static_cast<int64_t>(index + 1), summary.samples_total,
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }

  for (const auto& [split, by_mode] : per_split)
    for (const auto& [mode, instances] : by_mode)
      summary.scores[split][mode] = SplitScores{split_samples[split], average_metrics(instances)};
  return result;
}

std::string summary_json(const Summary& summary) {
  nlohmann::json scores = nlohmann::json::object();
  for (const auto& [split, by_mode] : summary.scores) {
    for (const auto& [mode, split_scores] : by_mode) {
      nlohmann::json entries = nlohmann::json::object();
      for (const auto& [name, score] : split_scores.entries)
        entries[name] = {{"rel", number(score.rel)},
                         {"delta1", number(score.delta1)},
                         {"count", score.count},
                         {"excluded", score.excluded}};
      scores[split][mode] = {{"samples", split_scores.samples}, {"entries", entries}};
    }
  }
  const nlohmann::json json{{"model", summary.model},
                            {"datasets", summary.datasets},
                            {"modes", summary.modes},
                            {"modes_not_supported", summary.modes_not_supported},
                            {"sparse_depth_points", summary.sparse_depth_points},
                            {"samples_total", summary.samples_total},
                            {"samples_evaluated", summary.samples_evaluated},
                            {"skipped", summary.skipped},
                            {"scores", scores}};
  return json.dump(2) + "\n";
}

std::string percent_cell(double value, bool rel) {
  const double percent = 100.0 * value;
  if (!std::isfinite(percent)) return "–";
  char text[32];
  std::snprintf(text, sizeof text, rel ? "%.2f" : "%.1f", percent);
  return text;
}

std::string markdown_table(const std::vector<Summary>& summaries) {
  std::vector<std::string> splits;
  for (const Split split : kSplits)
    for (const Summary& summary : summaries)
      if (summary.scores.count(split_name(split))) {
        splits.push_back(split_name(split));
        break;
      }
  std::string header = "| Model | Mode |", rule = "|---|---|";
  for (const auto& split : splits) {
    for (const char* column : {"depth Rel", "depth δ1", "points Rel", "points δ1", "metric δ1"}) {
      header += " " + split + " " + column + " |";
      rule += "---|";
    }
  }
  std::string table = header + "\n" + rule + "\n";
  const auto cell = [](const std::map<std::string, AveragedScore>* entries, const char* entry,
                       bool rel) {
    if (!entries || !entries->count(entry)) return std::string("–");
    const AveragedScore& score = entries->at(entry);
    return percent_cell(rel ? score.rel : score.delta1, rel);
  };
  for (const Summary& summary : summaries) {
    for (const auto& mode : summary.modes) {
      std::string row = "| " + summary.model + " | " + mode + " |";
      for (const auto& split : splits) {
        const std::map<std::string, AveragedScore>* entries = nullptr;
        const auto by_split = summary.scores.find(split);
        if (by_split != summary.scores.end()) {
          const auto by_mode = by_split->second.find(mode);
          if (by_mode != by_split->second.end()) entries = &by_mode->second.entries;
        }
        row += " " + cell(entries, "depth_scale_invariant", true) + " | " +
               cell(entries, "depth_scale_invariant", false) + " | " +
               cell(entries, "points_scale_invariant", true) + " | " +
               cell(entries, "points_scale_invariant", false) + " | " +
               cell(entries, "points_metric", false) + " |";
      }
      table += row + "\n";
    }
  }
  return table;
}

std::string write_run_files(const std::string& folder, const RunResult& result) {
  const std::filesystem::path out(folder);
  std::filesystem::create_directories(out);
  io::write_file_atomically((out / "samples.jsonl").string(), [&](std::ostream& stream) {
    for (const auto& record : result.records) stream << record << "\n";
  });
  io::write_file_atomically((out / "summary.json").string(),
                            [&](std::ostream& stream) { stream << summary_json(result.summary); });
  std::string table = markdown_table({result.summary});
  io::write_file_atomically((out / "table.md").string(),
                            [&](std::ostream& stream) { stream << table; });
  return table;
}

}  // namespace omnipoint::eval
