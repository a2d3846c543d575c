#pragma once
// PLY point clouds (the `points.ply` output of `omnipoint predict`).
// Writing: binary_little_endian 1.0, one `vertex` element with float x, y, z and (when
// colours are given) uchar red, green, blue. Reading: what we write and simple clouds from
// other tools: ascii or binary_little_endian 1.0; a first element `vertex` with scalar
// properties (char/uchar/short/ushort/int/uint/float/double or their int8...float64
// spellings) that include x, y, z and optionally uchar red, green, blue; later elements are
// ignored. Anything else (big-endian, list properties in `vertex`, truncated data, a
// malformed header) raises std::runtime_error naming the file and the problem.
#include <ATen/core/Tensor.h>

#include <string>

namespace omnipoint::io {

struct PlyPoints {
  at::Tensor points;  // (N, 3) float32
  at::Tensor colors;  // (N, 3) uint8; undefined when the file has no colours
};

// Writes points (N, 3) (any floating dtype, any device; stored as float32) and optional
// colours (N, 3) uint8 atomically. Bad shapes or dtypes raise std::invalid_argument.
void write_ply(const std::string& path, const at::Tensor& points, const at::Tensor& colors = {});

PlyPoints parse_ply(const std::string& bytes, const std::string& name = "ply");
PlyPoints read_ply(const std::string& path);

}  // namespace omnipoint::io
