#pragma once
// A tiny random OmniPoint checkpoint (examples/models/tiny_omnipoint.json, seed 0) in the temp
// folder, written once per test binary.
#include <ATen/ATen.h>

#include <filesystem>
#include <string>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/model/omnipoint_model.h"
#include "omnipoint/model/state_dict.h"

namespace omnipoint::predict {

inline std::string tiny_model_path() {
  static const std::string path = [] {
    const auto file = std::filesystem::temp_directory_path() / "omnipoint_predict_tiny.safetensors";
    const auto config = model::OmniPointConfig::from_json_text(
        io::read_file(std::string(OMNIPOINT_SOURCE_DIR) + "/examples/models/tiny_omnipoint.json"));
    at::manual_seed(0);
    model::OmniPointModel network(config);
    io::write_safetensors(file.string(), model::state_dict(*network),
                          model::omnipoint_metadata(config));
    return file.string();
  }();
  return path;
}

}  // namespace omnipoint::predict
