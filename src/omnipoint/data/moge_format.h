#pragma once
// MoGe's evaluation benchmark layout, so users who have those benchmarks can evaluate here:
//   ROOT/.index.txt            instance folder names, one per line (else: all subfolders)
//   ROOT/INSTANCE/image.jpg    RGB
//   ROOT/INSTANCE/depth.png    16-bit planar depth, log-encoded between `near` and `far`
//                              (PNG tEXt chunks): 0 unknown, 1..65534 the depth
//                              near^(1-t) * far^t with t = (v - 1) / 65533, 65535 infinity;
//                              an optional `unit` text chunk multiplies the depth
//   ROOT/INSTANCE/meta.json    {"intrinsics": 3x3 K normalised by the image size}
// The normalised K uses the same pixel convention as ours (the first pixel's centre at
// u = 0.5 / W), so fx = K00 * W, cx = K02 * W etc. for a PINHOLE camera.
#include <ATen/core/Tensor.h>

#include <string>
#include <vector>

#include "omnipoint/data/sample.h"

namespace omnipoint::data {

struct MogeDepthCode {
  at::Tensor values;  // (H, W) int32 in [0, 65535]
  double near = 0, far = 0;
};

// depth: (H, W) floating; NaN = unknown, +inf = infinity, finite values > 0.
// As MoGe's write_depth: near = max(min finite, 1e-5), far = max(1.1 near, min(max finite,
// near * max_range)); values clipped to [near, far].
MogeDepthCode encode_moge_depth(const at::Tensor& depth, double max_range = 1e5);
// float32 (H, W): NaN unknown, +inf infinity.
at::Tensor decode_moge_depth(const MogeDepthCode& code);

// The depth range a MoGe depth PNG carries in its text chunks: near, far and the optional
// unit (1 when absent). `png` is the file's bytes; a stream that is not a PNG, a missing or
// non-numeric chunk, or not 0 < near < far (finite) and unit > 0 (finite) ->
// std::runtime_error naming `name`.
struct MogeDepthRange {
  double near = 0, far = 0, unit = 1;
};
MogeDepthRange parse_moge_depth_range(const std::string& png, const std::string& name);

// The PINHOLE camera of an instance's meta.json text ({"intrinsics": 3x3 K normalised by the
// image size}) for an image of width x height. Bad JSON, a K that is not 3x3 numbers or
// intrinsics no camera has -> std::runtime_error naming `name`.
camera::Camera parse_moge_meta(const std::string& text, int64_t width, int64_t height,
                               const std::string& name);

void write_moge_depth(const std::string& path, const at::Tensor& depth);
at::Tensor read_moge_depth(const std::string& path);

// The instance folders of a benchmark root (full paths), from .index.txt when present.
std::vector<std::string> list_moge_instances(const std::string& root);
// One instance as a Sample (PINHOLE camera from the normalised intrinsics; unknown and
// infinite depths unlabelled). `metric` says whether the benchmark's depth is in metres.
Sample read_moge_instance(const std::string& folder, bool metric);

}  // namespace omnipoint::data
