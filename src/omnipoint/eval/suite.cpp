#include "omnipoint/eval/suite.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <ostream>
#include <set>
#include <stdexcept>
#include <utility>

#include "omnipoint/io/atomic_file.h"

namespace omnipoint::eval {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const std::vector<std::string> kModeNames{"none", "+K", "+D", "+K+D"};

// Errors name the source and the key: "FILE: sets[2].group: ...".
struct Reader {
  std::string source;
  [[noreturn]] void fail(const std::string& key, const std::string& problem) const {
    throw std::invalid_argument(source + ": " + key + ": " + problem);
  }
  const json& field(const json& object, const std::string& key, const std::string& where,
                    bool required) const {
    static const json absent;
    const auto found = object.find(key);
    if (found == object.end()) {
      if (required) fail(where + key, "missing");
      return absent;
    }
    return *found;
  }
  std::string text(const json& object, const std::string& key, const std::string& where,
                   bool required = true) const {
    const json& value = field(object, key, where, required);
    if (value.is_null() && !required) return "";
    if (!value.is_string()) fail(where + key, "expected a string");
    std::string result = value.get<std::string>();
    if (required && result.empty()) fail(where + key, "empty");
    return result;
  }
  bool flag(const json& object, const std::string& key, const std::string& where,
            bool fallback) const {
    const json& value = field(object, key, where, false);
    if (value.is_null()) return fallback;
    if (!value.is_boolean()) fail(where + key, "expected true or false");
    return value.get<bool>();
  }
  void only(const json& object, const std::set<std::string>& keys, const std::string& where) const {
    for (const auto& item : object.items())
      if (!keys.count(item.key())) fail(where + item.key(), "unknown key");
  }
};

std::string entry_name(const Reader& reader, const json& columns, const std::string& key,
                       const std::string& fallback) {
  std::string name = reader.text(columns, key, "columns.", false);
  if (name.empty()) return fallback;
  for (const char* entry : kMetricEntries)
    if (name == entry) return name;
  reader.fail("columns." + key, "\"" + name + "\" is no protocol entry (depth_metric, ...)");
}

SuiteSet parse_set(const Reader& reader, const json& object, const std::string& where,
                   const std::string& folder) {
  if (!object.is_object()) reader.fail(where.substr(0, where.size() - 1), "expected an object");
  reader.only(
      object,
      {"name", "group", "format", "root", "split", "options", "metric", "modes", "group_mean"},
      where);
  SuiteSet set;
  set.name = reader.text(object, "name", where);
  if (set.name.find_first_of("/\\") != std::string::npos || set.name == "." || set.name == "..")
    reader.fail(where + "name", "\"" + set.name + "\" must not be a path (it names a folder)");
  set.group = reader.text(object, "group", where);
  bool known_group = false;
  for (const Split split : kSplits) known_group |= set.group == split_name(split);
  if (!known_group) reader.fail(where + "group", "expected \"S.FoV\", \"L.FoV\" or \"360°\"");
  set.format = reader.text(object, "format", where);
  const std::vector<data::DatasetFormat> formats = data::dataset_format_list();
  const auto format = std::find_if(formats.begin(), formats.end(),
                                   [&](const auto& f) { return f.name == set.format; });
  if (format == formats.end())
    reader.fail(where + "format", "\"" + set.format + "\" is no dataset format (data formats)");
  set.root = reader.text(object, "root", where);
  if (fs::path(set.root).is_absolute())
    reader.fail(where + "root", "must be relative to the data root");
  set.split = reader.text(object, "split", where, false);
  const bool named =
      std::find(format->splits.begin(), format->splits.end(), set.split) != format->splits.end();
  if (!set.split.empty() && !named && fs::path(set.split).is_relative())
    set.split = (fs::path(folder) / set.split).lexically_normal().string();
  const json& options = reader.field(object, "options", where, false);
  if (!options.is_null()) {
    if (!options.is_object()) reader.fail(where + "options", "expected an object of strings");
    for (const auto& option : options.items()) {
      if (!option.value().is_string())
        reader.fail(where + "options." + option.key(), "expected a string");
      if (!format->options.count(option.key()))
        reader.fail(where + "options." + option.key(),
                    "format \"" + set.format + "\" has no such option");
      set.options[option.key()] = option.value().get<std::string>();
    }
  }
  set.metric = reader.flag(object, "metric", where, true);
  set.group_mean = reader.flag(object, "group_mean", where, true);
  const json& modes = reader.field(object, "modes", where, true);
  if (!modes.is_array() || modes.empty())
    reader.fail(where + "modes", "expected a list of modes (\"none\", \"+K\", \"+D\", \"+K+D\")");
  for (size_t i = 0; i < modes.size(); ++i) {
    const std::string key = where + "modes[" + std::to_string(i) + "]";
    if (!modes[i].is_string() || std::find(kModeNames.begin(), kModeNames.end(),
                                           modes[i].get<std::string>()) == kModeNames.end())
      reader.fail(key, "expected \"none\", \"+K\", \"+D\" or \"+K+D\"");
    if (std::find(set.modes.begin(), set.modes.end(), modes[i].get<std::string>()) !=
        set.modes.end())
      reader.fail(key, "listed twice");
    set.modes.push_back(modes[i].get<std::string>());
  }
  if (std::find(set.modes.begin(), set.modes.end(), "none") == set.modes.end())
    reader.fail(where + "modes", "must hold \"none\"");
  return set;
}

json number(double value) {
  return std::isfinite(value) ? json(value) : json();
}

// An entry's score as JSON: rel, delta1 (null when undefined), sets or samples averaged.
json score_json(const AveragedScore& score) {
  return {{"rel", number(score.rel)}, {"delta1", number(score.delta1)}, {"count", score.count}};
}

bool ran(const Summary& summary, const std::string& mode) {
  return std::find(summary.modes.begin(), summary.modes.end(), mode) != summary.modes.end();
}

}  // namespace

Suite parse_suite(const std::string& text, const std::string& source, const std::string& folder) {
  const Reader reader{source};
  json root;
  try {
    root = json::parse(text);
  } catch (const json::exception& error) {
    throw std::invalid_argument(source + ": not JSON (" + error.what() + ")");
  }
  if (!root.is_object()) throw std::invalid_argument(source + ": expected a JSON object");
  reader.only(root, {"name", "columns", "sets"}, "");
  Suite suite;
  suite.name = reader.text(root, "name", "");
  const json& columns = reader.field(root, "columns", "", false);
  if (!columns.is_null()) {
    if (!columns.is_object()) reader.fail("columns", "expected an object");
    reader.only(columns, {"depth", "points", "metric"}, "columns.");
    const SuiteColumns defaults;
    suite.columns.depth = entry_name(reader, columns, "depth", defaults.depth);
    suite.columns.points = entry_name(reader, columns, "points", defaults.points);
    suite.columns.metric = entry_name(reader, columns, "metric", defaults.metric);
  }
  const json& sets = reader.field(root, "sets", "", true);
  if (!sets.is_array() || sets.empty()) reader.fail("sets", "expected a list of sets");
  std::set<std::string> names;
  for (size_t i = 0; i < sets.size(); ++i) {
    const std::string where = "sets[" + std::to_string(i) + "].";
    SuiteSet set = parse_set(reader, sets[i], where, folder);
    if (!names.insert(set.name).second)
      reader.fail(where + "name", "\"" + set.name + "\" is the name of an earlier set");
    suite.sets.push_back(std::move(set));
  }
  return suite;
}

Suite read_suite(const std::string& path) {
  std::string text;
  try {
    text = io::read_file(path);
  } catch (const std::exception& error) {
    throw std::invalid_argument("suite " + path + ": cannot be read (" + error.what() + ")");
  }
  return parse_suite(text, path, fs::path(path).parent_path().string());
}

SuiteResult run_suite(const Predictor& predictor, const Suite& suite,
                      const SuiteRunOptions& options) {
  SuiteResult result;
  result.suite = suite;
  result.model = predictor.name;
  result.root = options.root;
  std::error_code error;
  if (!fs::is_directory(options.root, error))
    throw std::runtime_error("data root " + options.root + ": not a folder");
  std::vector<std::pair<const SuiteSet*, EvalDataset>> found;
  int64_t total = 0;
  for (const SuiteSet& set : suite.sets) {
    const fs::path root = fs::path(options.root) / set.root;
    if (!fs::exists(root, error)) {
      result.missing.push_back(set);
      continue;
    }
    data::DatasetLocation location{root.string(), set.metric, set.split, set.options};
    try {
      found.emplace_back(&set, open_eval_dataset({set.name, set.format, location}));
    } catch (const std::exception& e) {
      throw std::runtime_error("suite set " + set.name + ": " + e.what());
    }
    total += static_cast<int64_t>(found.back().second.items.size());
  }
  if (found.empty())
    throw std::runtime_error("data root " + options.root + ": holds none of the suite's " +
                             std::to_string(suite.sets.size()) + " sets");
  int64_t done = 0;
  for (const auto& [set, dataset] : found) {
    RunOptions run = options.run;
    run.modes.clear();
    for (const Mode& mode : options.modes)
      if (std::find(set->modes.begin(), set->modes.end(), mode.name()) != set->modes.end())
        run.modes.push_back(mode);
    if (options.run.progress)
      run.progress = [&, offset = done](int64_t index, int64_t, double seconds) {
        options.run.progress(offset + index, total, seconds);
      };
    RunResult scored = score_datasets(predictor, {dataset}, run);
    done += static_cast<int64_t>(dataset.items.size());
    for (std::string& record : scored.records) result.records.push_back(std::move(record));
    result.sets.push_back({*set, std::move(scored.summary)});
  }
  for (const std::string& mode : kModeNames)
    for (const SuiteSetScores& set : result.sets)
      if (ran(set.summary, mode)) {
        result.modes.push_back(mode);
        break;
      }
  return result;
}

AveragedScore set_score(const Summary& summary, const std::string& mode, const std::string& entry) {
  double rel = 0, delta1 = 0;
  int64_t count = 0, excluded = 0;
  for (const auto& [split, by_mode] : summary.scores) {
    const auto scores = by_mode.find(mode);
    if (scores == by_mode.end()) continue;
    const auto score = scores->second.entries.find(entry);
    if (score == scores->second.entries.end()) continue;
    excluded += score->second.excluded;
    if (score->second.count == 0) continue;
    rel += score->second.rel * static_cast<double>(score->second.count);
    delta1 += score->second.delta1 * static_cast<double>(score->second.count);
    count += score->second.count;
  }
  if (count == 0) return {NAN, NAN, 0, excluded};
  return {rel / static_cast<double>(count), delta1 / static_cast<double>(count), count, excluded};
}

AveragedScore group_score(const SuiteResult& result, const std::string& group,
                          const std::string& mode, const std::string& entry) {
  double rel = 0, delta1 = 0;
  int64_t sets = 0, excluded = 0;
  for (const SuiteSetScores& set : result.sets) {
    if (set.set.group != group || !set.set.group_mean) continue;
    const AveragedScore score = set_score(set.summary, mode, entry);
    if (!std::isfinite(score.rel) || !std::isfinite(score.delta1)) {
      excluded += ran(set.summary, mode) ? 1 : 0;
      continue;
    }
    rel += score.rel;
    delta1 += score.delta1;
    ++sets;
  }
  if (sets == 0) return {NAN, NAN, 0, excluded};
  return {rel / static_cast<double>(sets), delta1 / static_cast<double>(sets), sets, excluded};
}

std::string suite_markdown(const SuiteResult& result) {
  const SuiteColumns& columns = result.suite.columns;
  std::string text = "# " + result.suite.name + ": " + result.model + "\n\n";
  text += "Depth: " + columns.depth + "; points: " + columns.points +
          "; metric δ1: " + columns.metric +
          ". Rel and δ1 in percent; a group is the mean of its sets.\n\n";
  std::string header = "| Mode |", rule = "|---|";
  for (const Split split : kSplits)
    for (const char* column : {"depth Rel", "depth δ1", "points Rel", "points δ1"}) {
      header += " " + split_name(split) + " " + column + " |";
      rule += "---|";
    }
  text += header + "\n" + rule + "\n";
  for (const std::string& mode : result.modes) {
    text += "| " + mode + " |";
    for (const Split split : kSplits)
      for (const std::string* entry : {&columns.depth, &columns.points}) {
        const AveragedScore score = group_score(result, split_name(split), mode, *entry);
        text +=
            " " + percent_cell(score.rel, true) + " | " + percent_cell(score.delta1, false) + " |";
      }
    text += "\n";
  }
  text +=
      "\n| Set | Group | Samples | Mode | depth Rel | depth δ1 | points Rel | points δ1 | metric "
      "δ1 |\n|---|---|---|---|---|---|---|---|---|\n";
  for (const SuiteSetScores& set : result.sets)
    for (const std::string& mode : set.summary.modes) {
      text += "| " + set.set.name + (set.set.group_mean ? "" : " (not in the group mean)") + " | " +
              set.set.group + " | " + std::to_string(set.summary.samples_evaluated) + " | " + mode +
              " |";
      for (const std::string* entry : {&columns.depth, &columns.points}) {
        const AveragedScore score = set_score(set.summary, mode, *entry);
        text +=
            " " + percent_cell(score.rel, true) + " | " + percent_cell(score.delta1, false) + " |";
      }
      text +=
          " " + percent_cell(set_score(set.summary, mode, columns.metric).delta1, false) + " |\n";
    }
  if (!result.missing.empty()) {
    text += "\nNot found under " + result.root + ":";
    for (const SuiteSet& set : result.missing) text += " " + set.name + " (" + set.root + ")";
    text += "\n";
  }
  return text;
}

std::string suite_json(const SuiteResult& result) {
  const SuiteColumns& columns = result.suite.columns;
  const auto entries = [&](const auto& score_of) {
    json by_mode = json::object();
    for (const std::string& mode : result.modes) {
      json scores = json::object();
      const std::array<std::pair<const char*, const std::string*>, 3> named{
          {{"depth", &columns.depth}, {"points", &columns.points}, {"metric", &columns.metric}}};
      for (const auto& [column, entry] : named) {
        const AveragedScore score = score_of(mode, *entry);
        if (score.count > 0) scores[column] = score_json(score);
      }
      if (!scores.empty()) by_mode[mode] = scores;
    }
    return by_mode;
  };
  json groups = json::object();
  for (const Split split : kSplits) {
    const std::string group = split_name(split);
    groups[group] = entries([&](const std::string& mode, const std::string& entry) {
      return group_score(result, group, mode, entry);
    });
  }
  json sets = json::array();
  for (const SuiteSetScores& set : result.sets)
    sets.push_back({{"name", set.set.name},
                    {"group", set.set.group},
                    {"group_mean", set.set.group_mean},
                    {"samples_total", set.summary.samples_total},
                    {"samples_evaluated", set.summary.samples_evaluated},
                    {"skipped", set.summary.skipped},
                    {"modes_not_supported", set.summary.modes_not_supported},
                    {"scores", entries([&](const std::string& mode, const std::string& entry) {
                       return set_score(set.summary, mode, entry);
                     })},
                    {"summary", json::parse(summary_json(set.summary))}});
  json missing = json::array();
  for (const SuiteSet& set : result.missing)
    missing.push_back({{"name", set.name}, {"group", set.group}, {"root", set.root}});
  const json table{
      {"suite", result.suite.name},
      {"model", result.model},
      {"root", result.root},
      {"columns",
       {{"depth", columns.depth}, {"points", columns.points}, {"metric", columns.metric}}},
      {"modes", result.modes},
      {"groups", groups},
      {"sets", sets},
      {"missing", missing}};
  return table.dump(2) + "\n";
}

std::string write_suite_files(const std::string& folder, const SuiteResult& result) {
  const fs::path out(folder);
  fs::create_directories(out);
  io::write_file_atomically((out / "samples.jsonl").string(), [&](std::ostream& stream) {
    for (const auto& record : result.records) stream << record << "\n";
  });
  std::string table = suite_markdown(result);
  io::write_file_atomically((out / "table.json").string(),
                            [&](std::ostream& stream) { stream << suite_json(result); });
  io::write_file_atomically((out / "table.md").string(),
                            [&](std::ostream& stream) { stream << table; });
  return table;
}

}  // namespace omnipoint::eval
