// omnipoint models: published checkpoints fetched by name into the cache (io/hub.h).
//   models pull NAME...  downloads (or finds) each and prints "NAME -> PATH (SIZE)"
//   models list          the cache's files, one line each: REFERENCE  SIZE  commit C  PATH
#include <CLI/CLI.hpp>

#include <iostream>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/download_report.h"
#include "omnipoint/io/hub.h"

namespace omnipoint::cli {

namespace {

std::string short_name_help() {
  std::string text;
  for (const io::hub::ShortName& name : io::hub::short_names())
    text += "\n  " + name.name + ": " + name.repo + ", " + name.description;
  return text;
}

void pull(const std::vector<std::string>& names) {
  const io::hub::Settings settings = io::hub::Settings::from_environment();
  for (const std::string& name : names) {
    DownloadReport report;
    const io::hub::CachedModel model =
        io::hub::fetch_model(io::hub::parse_model_reference(name), settings, &report);
    std::cout << model.reference.text() << " -> " << model.path.string() << " ("
              << io::hub::human_bytes(model.bytes)
              << (model.downloaded ? ", downloaded" : ", already cached") << ")\n";
  }
}

void list() {
  const io::hub::Settings settings = io::hub::Settings::from_environment();
  const std::vector<io::hub::CachedModel> models = io::hub::cached_models(settings.cache);
  if (models.empty()) {
    std::cerr << "omnipoint: the cache (" << settings.cache.string()
              << ") holds no model; fetch one with: omnipoint models pull moge-2-vitl-normal\n";
    return;
  }
  for (const io::hub::CachedModel& model : models)
    std::cout << model.reference.text() << "  " << io::hub::human_bytes(model.bytes) << "  commit "
              << model.commit.substr(0, 12) << "  " << model.path.string() << "\n";
}

}  // namespace

void add_models_command(CLI::App& app) {
  CLI::App* models = app.add_subcommand(
      "models",
      "Published models fetched by name from the Hugging Face hub into the cache "
      "($OMNIPOINT_CACHE, default ~/.cache/omnipoint; HF_ENDPOINT, HF_TOKEN, HF_HUB_OFFLINE=1)");
  models->require_subcommand(1);
  auto names = std::make_shared<std::vector<std::string>>();
  CLI::App* pull_command = models->add_subcommand(
      "pull",
      "Download models into the cache (resuming an interrupted download, verifying its checksum) "
      "and print their local paths. NAME: hf:OWNER/REPO[/FILE][@REVISION] or a short name:" +
          short_name_help());
  pull_command->add_option("names", *names, "The models")->required();
  pull_command->callback([names] { pull(*names); });
  models->add_subcommand("list", "List the models in the cache: reference, size, commit, path")
      ->callback(list);
}

}  // namespace omnipoint::cli
