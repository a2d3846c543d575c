// omnipoint data formats|check|convert: the dataset readers and what each needs, what a dataset
// folder holds as its reader sees it, and a dataset converted into sample folders.
#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/dataset_options.h"
#include "cli/progress.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/dataset_check.h"
#include "omnipoint/data/dataset_convert.h"

namespace omnipoint::cli {
namespace {

void add_formats_command(CLI::App& parent) {
  auto* command = parent.add_subcommand(
      "formats",
      "List the dataset formats: what each expects under its root, its options "
      "(--option NAME=VALUE) and its named splits");
  command->callback([] {
    for (const data::DatasetFormat& format : data::dataset_format_list()) {
      std::cout << format.name << "\n  " << format.summary << "\n";
      for (const auto& [name, help] : format.options)
        std::cout << "  option " << name << ": " << help << "\n";
      if (!format.splits.empty()) {
        std::cout << "  splits:";
        for (const std::string& split : format.splits) std::cout << " " << split;
        std::cout << "\n";
      }
    }
  });
}

nlohmann::json report_json(const data::DatasetCheckReport& report) {
  return {
      {"items", report.items},
      {"read", report.read},
      {"failed", report.failed},
      {"missing_files", report.missing},
      {"camera_models", report.camera_models},
      {"metric_items", report.metric_items},
      {"label_density",
       {{"min", report.density_min}, {"mean", report.density_mean}, {"max", report.density_max}}},
      {"distance_range", {report.distance_min, report.distance_max}}};
}

// The options naming a dataset on disk, as `check` and `convert` take them: its format, root,
// split, format options (NAME=VALUE, parsed into location.options by the callback) and --metric.
void add_dataset_options(CLI::App* command, std::string& format, data::DatasetLocation& location,
                         std::vector<std::string>& given) {
  command->add_option("--format", format, "The dataset's format (`data formats`)")->required();
  command->add_option("--root", location.path, "The dataset's root folder")->required();
  command->add_option("--split", location.split,
                      "One of the format's named splits, or a split list file");
  command->add_option("--option", given, "A format option NAME=VALUE (repeatable)");
  command->add_flag("--metric", location.metric,
                    "Formats without their own flag (moge): the depth is in metres");
}

void add_check_command(CLI::App& parent) {
  auto* command = parent.add_subcommand(
      "check",
      "Read a dataset through its format's reader and print, as JSON, the items found, "
      "missing files, items that do not read, camera models, label density and "
      "distance range; exits 1 when files are missing or items do not read");
  auto options = std::make_shared<data::DatasetCheckOptions>();
  auto given = std::make_shared<std::vector<std::string>>();
  add_dataset_options(command, options->format, options->location, *given);
  command->add_option("--limit", options->limit,
                      "Read this many items, spread over the dataset (default 0: all)");
  command->add_option("--sheet", options->sheet_path,
                      "Write a contact sheet PNG (image | distance) of a few items");
  command->add_option("--sheet-items", options->sheet_items, "Items on the sheet (default 4)");
  command->callback([options, given] {
    parse_format_options(*given, options->location.options);
    const data::DatasetCheckReport report = data::DatasetCheck(*options).Run();
    std::cout << report_json(report).dump(2) << "\n";
    if (report.ok()) return;
    throw std::runtime_error(
        "data check: " + std::to_string(report.missing.size()) + " missing files, " +
        std::to_string(report.failed.size()) + " of " + std::to_string(report.read) +
        " items do not read (first: " +
        (report.missing.empty() ? report.failed.front() : report.missing.front() + " missing") +
        ")");
  });
}

// Progress on stderr, a warning line per skipped item.
class ConvertReports : public data::DatasetConvertObserver {
 public:
  void on_start(int64_t items) override { progress_.emplace(items); }
  void on_item(int64_t ordinal, const data::ConvertedItem& item) override {
    progress_->start(ordinal, item.folder);
  }
  void on_skipped(const data::ConvertedItem& /*item*/, const std::string& why) override {
    progress_->line("omnipoint: warning: " + progress_->prefix() + "skipped " + why);
  }
  void on_item_done(int64_t /*ordinal*/) override { progress_->done(); }

 private:
  std::optional<Progress> progress_;
};

void add_convert_command(CLI::App& parent) {
  auto* command = parent.add_subcommand(
      "convert",
      "Write a dataset's items as sample folders (image.png, distance.npy, mask.png, meta.json; "
      "docs/DATASET.md) and OUT/manifest.jsonl; an item that does not read is skipped with a "
      "warning; exits 1 when nothing was converted");
  auto options = std::make_shared<data::DatasetConvertOptions>();
  auto given = std::make_shared<std::vector<std::string>>();
  add_dataset_options(command, options->format, options->location, *given);
  command->add_option("--out", options->output_path, "The folder of sample folders to write")
      ->required();
  command->add_option("--camera", options->camera,
                      "The dataset's camera name (image_02): the format's option camera");
  command->add_option("--sequence", options->sequence,
                      "The dataset's sequence/scene names: the format's option sequence");
  command->add_option("--every", options->every, "Every K-th item (default 1)");
  command->add_option("--limit", options->limit, "At most N items (default 0: all)");
  command->add_flag("--resume", options->resume,
                    "Keep the items whose sample folders exist in --out (an interrupted run)");
  command->add_flag("--overwrite", options->overwrite,
                    "Write every item anew into an --out that holds files already");
  command->callback([options, given] {
    parse_format_options(*given, options->location.options);
    ConvertReports reports;
    const data::DatasetConvertReport report = data::DatasetConvert(*options, &reports).Run();
    std::cout << "converted " << report.converted << ", kept " << report.kept << ", skipped "
              << report.skipped.size() << " of " << report.items << " items into "
              << options->output_path << " (" << report.manifest_path << ")\n";
  });
}

}  // namespace

void add_data_command(CLI::App& app) {
  auto* data = app.add_subcommand(
      "data",
      "Datasets on disk: the formats read, checking a dataset folder, converting it to sample "
      "folders");
  data->require_subcommand(1);
  add_formats_command(*data);
  add_check_command(*data);
  add_convert_command(*data);
}

}  // namespace omnipoint::cli
