#pragma once
// OmniPoint weights: initialisation from a MoGe-2 or a DINOv2 checkpoint, and the tensors and
// metadata of our own checkpoints. No files here (docs/DESIGN.md: io sits at the edge): read and
// write them with omnipoint/io/safetensors.h, e.g.
//   io::write_safetensors(path, state_dict(*model), omnipoint_metadata(model->config()), at::kHalf);
//   const io::SafetensorsFile file = io::read_safetensors(path);
//   OmniPointModel model = load_omnipoint_model(file.tensors, file.metadata);
#include <ATen/core/Tensor.h>

#include <map>
#include <string>
#include <vector>

#include "omnipoint/model/moge2.h"
#include "omnipoint/model/omnipoint_model.h"

namespace omnipoint::model {

// What an initialisation did, by the model's tensor names (sorted).
struct InitReport {
  std::vector<std::string> loaded;   // copied by name from the checkpoint
  std::vector<std::string> derived;  // "name <- source: how", built from other checkpoint tensors
  std::vector<std::string> kept;     // left as constructed (conditioning, fresh heads)
  std::vector<std::string> ignored;  // checkpoint tensors used for nothing
  std::string summary() const;       // one line per group with its count and names
};

// From a MoGe-2 state dict (MoGe-2's names) of the model `moge2` configures, which should be
// what OmniPointConfig::from_moge2 made the model's config from. Strict on the shared parts:
// every encoder, neck, mask-head and scale-head tensor must be there with its shape, else
// std::runtime_error listing the problems and nothing is loaded. Heads:
//   xyz:          points_head by name.
//   ray_distance: ray_head and distance_head take every points_head tensor but the output
//                 conv; the ray output conv takes the points head's x and y rows and a constant
//                 1 for its third channel (bias 1, weights 0), so r̂ = normalise(a, b, 1) is
//                 exactly MoGe-2's ray direction under the exp remap (a·e^c, b·e^c, e^c); the
//                 distance output conv takes the z row, log d̂ = c, i.e. d̂ = MoGe-2's z, which
//                 misses the factor sqrt(1 + a² + b²) of the distance and is left to training.
// The conditioning keeps its zero-initialised fusion: with conditions absent the encoder
// features are MoGe-2's.
InitReport init_from_moge2(OmniPointModelImpl& model,
                           const std::map<std::string, at::Tensor>& moge2,
                           const MoGe2Config& moge2_config);

// From a DINOv2 backbone state dict, bare (`blocks.0.attn.qkv.weight`, as torch.hub ships it)
// or prefixed (`encoder.backbone.…` as in MoGe-2 and OmniPoint, `backbone.…` as in MoGe-1). Strict on the backbone; everything else is kept.
InitReport init_from_dinov2(OmniPointModelImpl& model,
                            const std::map<std::string, at::Tensor>& dinov2);

// A model built from checkpoint metadata (omnipoint_metadata) and loaded strictly from its
// tensors, built without random initialisation and sharing the tensors where their dtype is
// the model's (LoadStorage::kShare: no copy of a memory-mapped checkpoint); errors as
// load_state_dict and config_from_metadata.
OmniPointModel load_omnipoint_model(const std::map<std::string, at::Tensor>& tensors,
                                    const std::map<std::string, std::string>& metadata);

}  // namespace omnipoint::model
