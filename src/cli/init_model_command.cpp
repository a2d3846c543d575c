// omnipoint init-model: a randomly initialised OmniPoint checkpoint from a config file — the
// starting point of a training run, and a stand-in model for trying the pipeline end to end
// (its predictions are meaningless until trained).
#include <ATen/ATen.h>
#include <CLI/CLI.hpp>

#include <cstdint>
#include <iostream>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/model/omnipoint_model.h"
#include "omnipoint/model/state_dict.h"

namespace omnipoint::cli {

namespace {

struct InitModelOptions {
  std::string config_path;
  std::string out_path;
  uint64_t seed = 0;
};

void run_init_model(const InitModelOptions& options) {
  model::OmniPointConfig config;
  try {
    config = model::OmniPointConfig::from_json_text(io::read_file(options.config_path));
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("config " + options.config_path + ": " + e.what());
  }
  at::manual_seed(options.seed);
  model::OmniPointModel network(config);
  io::write_safetensors(options.out_path, model::state_dict(*network),
                        model::omnipoint_metadata(config));
  std::cout << "wrote " << options.out_path << " (random weights, seed " << options.seed << ")\n";
}

}  // namespace

void add_init_model_command(CLI::App& app) {
  auto options = std::make_shared<InitModelOptions>();
  CLI::App* command = app.add_subcommand(
      "init-model",
      "Write a randomly initialised OmniPoint checkpoint (.safetensors) from a config JSON");
  command
      ->add_option("--config", options->config_path,
                   "OmniPoint config JSON (model/omnipoint_config.h)")
      ->required()
      ->check(CLI::ExistingFile);
  command->add_option("--out", options->out_path, "Output .safetensors file")->required();
  command->add_option("--seed", options->seed, "Random seed of the initialisation (default 0)");
  command->callback([options] { run_init_model(*options); });
}

}  // namespace omnipoint::cli
