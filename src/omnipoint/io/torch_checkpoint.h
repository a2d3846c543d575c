#pragma once
// PyTorch checkpoints (torch.save, PyTorch >= 1.6), read without Python.
//
// The file is a zip (io/zip_archive.h) of records under one folder: PREFIX/data.pkl, the
// pickled object (read by the restricted unpickler of io/pickle.h, which refuses any global
// but tensors' and OrderedDict's), and PREFIX/data/KEY, the raw little-endian bytes of each
// tensor storage (PREFIX/byteorder says "little" where present). The pre-1.6 format (a bare
// pickle stream) and TorchScript archives are refused with a line saying what to do.
#include <ATen/core/Tensor.h>

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "omnipoint/io/pickle.h"

namespace omnipoint::io {

// Parses a checkpoint held in memory. With `keep_alive` (the owner of `data`), tensors are
// views of the buffer where their bytes are aligned for their dtype, and keep it alive;
// without it every storage is copied, and the buffer may be freed afterwards.
PickleValue parse_torch_checkpoint(const char* data, std::size_t size, const std::string& source,
                                   std::shared_ptr<const void> keep_alive = nullptr);

// Reads a checkpoint file, memory-mapped (copy-on-write: writing to a tensor never touches the
// file); the tensors keep the mapping alive.
PickleValue read_torch_checkpoint(const std::string& path);

// Whether the bytes begin like the pre-1.6 format (a pickle stream), and the line that refuses it.
bool looks_like_legacy_torch(const char* data, std::size_t size);
std::string legacy_torch_message(const std::string& source);

// Named tensors and string metadata: what a weights file holds, of either format.
struct WeightsFile {
  std::map<std::string, at::Tensor> tensors;
  std::map<std::string, std::string> metadata;
};

// A checkpoint's object as weights, in the layouts tools/convert_checkpoint.py converts:
//   MoGe's {'model_config': dict, 'model': state dict} (MoGe-2's and MoGe-1's model.pt)
//        -> metadata {"format": "moge2", "config": model_config as JSON}
//   a bare state dict (name -> tensor, e.g. DINOv2's hub .pth)
//        -> metadata {"format": "state_dict"}
// Tensors keep their stored dtype and layout. std::runtime_error naming `source` otherwise.
WeightsFile checkpoint_weights(const PickleValue& checkpoint, const std::string& source);

// A .safetensors file or a PyTorch checkpoint, told apart by content, as weights: floating-point
// tensors converted to `convert_to` (std::nullopt keeps every stored dtype), every tensor
// contiguous. Errors name the path: std::runtime_error.
WeightsFile read_weights(const std::string& path,
                         std::optional<at::ScalarType> convert_to = at::kFloat);

}  // namespace omnipoint::io
