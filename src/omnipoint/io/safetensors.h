#pragma once
// Safetensors weights files (docs/DESIGN.md: weights are .safetensors, never pickle).
//
// Layout: an 8-byte little-endian u64 N, an N-byte UTF-8 JSON header, then the raw tensor
// bytes. The header maps each tensor name to {"dtype", "shape", "data_offsets": [begin, end]}
// (byte offsets relative to the end of the header; data C-contiguous, little-endian) and may
// hold "__metadata__", a string -> string map (ours carries the model config as JSON).
// As in the reference implementation, the tensors must tile the data section exactly: no
// overlaps, no holes, no trailing bytes.
//
// Dtypes: F64, F32, F16, BF16, I64, I32, I16, I8, U8, BOOL. Every structural problem
// raises std::runtime_error with one message naming the file and the problem.
#include <ATen/core/Tensor.h>

#include <cstddef>
#include <map>
#include <memory>
#include <optional>
#include <string>

namespace omnipoint::io {

struct SafetensorsFile {
  std::map<std::string, at::Tensor> tensors;    // contiguous CPU tensors
  std::map<std::string, std::string> metadata;  // "__metadata__" (empty if absent)
};

// Parses an in-memory safetensors image; tensors keep their stored dtype and own their
// memory (the buffer may be freed afterwards). `name` is used in error messages. With
// `keep_alive` (the owner of `data`), tensors whose bytes are aligned for their dtype are views
// of the buffer instead and keep it alive.
SafetensorsFile parse_safetensors(const char* data, std::size_t size,
                                  const std::string& name = "safetensors",
                                  const std::shared_ptr<const void>& keep_alive = nullptr);

// Reads a safetensors file (memory-mapped). Floating-point tensors are converted to
// `convert_to` (a floating-point type); std::nullopt keeps every stored dtype. Integer and
// bool tensors always keep theirs.
SafetensorsFile read_safetensors(const std::string& path,
                                 std::optional<at::ScalarType> convert_to = at::kFloat);

// Serialises tensors (any device; made contiguous on CPU) and metadata to safetensors bytes,
// byte-compatible with the Python `safetensors` package: compact JSON, "__metadata__"
// first (keys sorted; omitted when empty), data ordered by dtype alignment (widest first)
// then by name, header padded with spaces to a multiple of 8 bytes. Floating-point tensors
// are stored as `store_as` when given. Unsupported dtypes or names that are not valid UTF-8
// raise std::invalid_argument.
std::string encode_safetensors(const std::map<std::string, at::Tensor>& tensors,
                               const std::map<std::string, std::string>& metadata = {},
                               std::optional<at::ScalarType> store_as = std::nullopt);

// Writes encode_safetensors(...) to `path` atomically.
void write_safetensors(const std::string& path, const std::map<std::string, at::Tensor>& tensors,
                       const std::map<std::string, std::string>& metadata = {},
                       std::optional<at::ScalarType> store_as = std::nullopt);

}  // namespace omnipoint::io
