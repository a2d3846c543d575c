#pragma once
// Named tensors in and out of a torch::nn::Module. Names are the module's registered dotted
// names (named_parameters() and named_buffers()), so a module tree registered with MoGe-2's
// names loads MoGe-2 checkpoints as they are. No files here: callers read the weights
// (omnipoint/io/safetensors.h) and pass the tensors in.
#include <ATen/core/Tensor.h>

#include <map>
#include <string>
#include <vector>

namespace torch::nn {
class Module;
}

namespace omnipoint::model {

enum class LoadMode {
  kStrict,   // every module tensor present with its shape, nothing else: or nothing loads
  kPartial,  // explicit, for initialisation: load what matches by name and shape
};

enum class LoadStorage {
  kCopy,   // the module keeps its own memory; the values are copied into it
  kShare,  // the module's tensors become the given ones where dtype and device agree (no copy:
           // for a checkpoint memory-mapped copy-on-write, the module then reads the file's
           // pages); the rest are converted copies. The caller must not change them afterwards.
};

// Sorted names. `mismatched` are names present on both sides whose shapes differ (dtypes
// may differ: values are converted to the module's dtype, as PyTorch's load_state_dict does).
struct LoadReport {
  std::vector<std::string> loaded, missing, unexpected, mismatched;
};

// Loads `tensors` into the module's parameters and buffers (without autograd, keeping the
// module's dtype and device), by copy or by sharing (`storage`). Strict mode throws one
// std::runtime_error listing every missing, unexpected and mismatched name (long lists
// truncated) and then leaves the module untouched; partial mode loads the matches and reports
// the rest.
LoadReport load_state_dict(torch::nn::Module& module,
                           const std::map<std::string, at::Tensor>& tensors, LoadMode mode,
                           LoadStorage storage = LoadStorage::kCopy);

// The module's parameters and buffers by dotted name, detached; they share memory with the
// module (clone them to keep a snapshot across training steps).
std::map<std::string, at::Tensor> state_dict(const torch::nn::Module& module);

}  // namespace omnipoint::model
