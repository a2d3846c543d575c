#pragma once
// What the training tests share: a tiny network and a five-step config on synthetic data
// (stage 1, 2 and 3), scratch folders and the losses a run's log holds.
#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <unistd.h>

#include <cstdint>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/train/trainer.h"
#include "support/tiny_omnipoint.h"

namespace omnipoint::train {

inline nlohmann::json tiny_model_json() {
  return nlohmann::json::parse(
      test::tiny_omnipoint_config_json("ray_distance", R"({"encoder_dim": 8, "splat_radius": 2})"));
}

inline nlohmann::json tiny_config(const std::string& output_dir) {
  using nlohmann::json;
  return {
      {"output_dir", output_dir},
      {"seed", 5},
      {"threads", 1},
      {"model", tiny_model_json()},
      {"data",
       {{"batch_size", 2},
        {"image_size", {28, 28}},
        {"num_tokens", {2, 4}},
        {"datasets",
         {{{"weight", 1},
           {"synth",
            {{"scenes", {"indoor", "outdoor", "object"}},
             {"cameras",
              {"PINHOLE 28 28 20 20 14 14", "OPENCV_FISHEYE 28 28 9 9 14 14 0 0 0 0"}}}}}}}}},
      {"conditions", {{"probability", 0.9}, {"sparse_ratio", {0.005, 0.01}}}},
      {"loss", {{"local", {{"levels", {4}}, {"patches_per_item", 4}, {"min_points", 8}}}}},
      {"ema", {{"decay", 0.9}}},
      {"stages",
       {{{"stage", 1}, {"steps", 2}, {"lr_backbone", 1e-3}, {"lr_heads", 1e-3}, {"decay_every", 1}},
        {{"stage", 2}, {"steps", 2}, {"lr_backbone", 5e-4}, {"lr_heads", 5e-4}},
        {{"stage", 3}, {"steps", 1}, {"lr_backbone", 0}, {"lr_heads", 1e-3}}}},
      {"checkpoint_every", 0},
      {"log_every", 1}};
}

inline model::OmniPointModel tiny_model(const TrainConfig& config) {
  at::manual_seed(11);
  return build_model(config);
}

inline std::string temp_dir(const std::string& name) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("omnipoint_train_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

// The loss of each step record of a log.jsonl.
inline std::map<int64_t, double> losses_by_step(const std::string& log) {
  std::map<int64_t, double> losses;
  std::istringstream lines(io::read_file(log));
  std::string line;
  while (std::getline(lines, line)) {
    const nlohmann::json record = nlohmann::json::parse(line);
    if (record.contains("loss"))
      losses[record.at("step").get<int64_t>()] = record.at("loss").get<double>();
  }
  return losses;
}

}  // namespace omnipoint::train
