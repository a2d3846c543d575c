#pragma once
// Training checkpoints on disk. A run's checkpoint folder holds one sub-folder per saved step
// and a pointer to the newest complete one:
//   DIR/step_00001000/model.safetensors      the model, config in __metadata__ (loadable by predict)
//                     ema.safetensors        the EMA weights, same format
//                     optimizer.safetensors  AdamW moments and steps by parameter name
//                     rng.safetensors        generator states
//                     progress.json          step, skipped-step counter, optimiser stage
//   DIR/latest                               "step_00001000"
// Writing is atomic: the files go into a staging folder (io::StagedFolder), which is renamed
// when complete, and only then `latest` is replaced (itself atomically), so a kill at any
// moment leaves the previous checkpoint intact and referenced.
#include <string>

#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/train/trainer.h"

namespace omnipoint::train {

// Returns the folder written.
std::string write_checkpoint(const std::string& dir, const TrainState& state,
                             const model::OmniPointConfig& config);

// `path`: a step folder, a checkpoint folder (its `latest`), or a run's output folder (its
// checkpoints/latest). std::runtime_error naming the path when nothing complete is there.
TrainState read_checkpoint(const std::string& path);
// The step folder `path` resolves to, as read_checkpoint does.
std::string resolve_checkpoint(const std::string& path);

}  // namespace omnipoint::train
