#include "omnipoint/train/checkpoint.h"

#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/io/staged_folder.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;

std::string step_name(int64_t step) {
  char name[32];
  std::snprintf(name, sizeof(name), "step_%08lld", static_cast<long long>(step));
  return name;
}

std::string trim(std::string text) {
  while (!text.empty() && (text.back() == '\n' || text.back() == ' ' || text.back() == '\r'))
    text.pop_back();
  return text;
}

void write_text(const std::string& path, const std::string& text) {
  io::write_file_atomically(path, [&](std::ostream& out) { out << text; });
}

}  // namespace

std::string write_checkpoint(const std::string& dir, const TrainState& state,
                             const model::OmniPointConfig& config) {
  const std::string name = step_name(state.progress.at("step").get<int64_t>());
  io::StagedFolder staged(fs::path(dir) / name);
  const fs::path& partial = staged.path();
  const auto metadata = model::omnipoint_metadata(config);
  io::write_safetensors((partial / "model.safetensors").string(), state.model, metadata);
  io::write_safetensors((partial / "ema.safetensors").string(), state.ema, metadata);
  io::write_safetensors((partial / "optimizer.safetensors").string(), state.optimizer);
  io::write_safetensors((partial / "rng.safetensors").string(), state.rng);
  write_text((partial / "progress.json").string(), state.progress.dump(2) + "\n");
  staged.commit();
  write_text((fs::path(dir) / "latest").string(), name + "\n");
  return staged.destination().string();
}

std::string resolve_checkpoint(const std::string& path) {
  const fs::path root(path);
  if (fs::exists(root / "progress.json")) return root.string();
  for (const fs::path& dir : {root, root / "checkpoints"}) {
    if (fs::exists(dir / "latest")) {
      const fs::path step = dir / trim(io::read_file((dir / "latest").string()));
      if (fs::exists(step / "progress.json")) return step.string();
      throw std::runtime_error("checkpoint \"" + path +
                               "\": \"latest\" points to a missing folder " + step.string());
    }
  }
  throw std::runtime_error("checkpoint \"" + path +
                           "\": not a checkpoint (expected progress.json, or a \"latest\" file in "
                           "it or in checkpoints/)");
}

TrainState read_checkpoint(const std::string& path) {
  const fs::path dir(resolve_checkpoint(path));
  TrainState state;
  io::SafetensorsFile model_file =
      io::read_safetensors((dir / "model.safetensors").string(), std::nullopt);
  state.model = std::move(model_file.tensors);
  state.model_metadata = std::move(model_file.metadata);
  state.ema = io::read_safetensors((dir / "ema.safetensors").string(), std::nullopt).tensors;
  state.optimizer =
      io::read_safetensors((dir / "optimizer.safetensors").string(), std::nullopt).tensors;
  state.rng = io::read_safetensors((dir / "rng.safetensors").string(), std::nullopt).tensors;
  try {
    state.progress = nlohmann::json::parse(io::read_file((dir / "progress.json").string()));
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error("checkpoint \"" + dir.string() +
                             "\": progress.json is not valid JSON: " + e.what());
  }
  return state;
}

}  // namespace omnipoint::train
