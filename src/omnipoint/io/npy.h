#pragma once
// NumPy .npy arrays: the exchange format with other tools (docs/DESIGN.md).
// Supported dtypes: float32 (<f4), float64 (<f8), uint8 (|u1), bool (|b1), int32 (<i4),
// int64 (<i8); C order only; format versions 1.0, 2.0 and 3.0 on read, 1.0 on write.
// Every structural problem (bad magic, malformed header, Fortran order, unsupported or
// big-endian dtype, size mismatch, trailing bytes) raises std::runtime_error naming it.
#include <ATen/core/Tensor.h>

#include <cstddef>
#include <string>

namespace omnipoint::io {

// Parses an in-memory .npy image; `name` is used in error messages.
at::Tensor parse_npy(const char* data, std::size_t size, const std::string& name = "npy");
// Reads a .npy file into a contiguous CPU tensor of the stored dtype.
at::Tensor read_npy(const std::string& path);
// Serialises a tensor (any device, made contiguous on CPU) to .npy bytes.
std::string encode_npy(const at::Tensor& tensor);
// Writes a tensor to a .npy file atomically.
void write_npy(const std::string& path, const at::Tensor& tensor);

}  // namespace omnipoint::io
