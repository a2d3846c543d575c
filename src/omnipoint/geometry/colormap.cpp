#include "omnipoint/geometry/colormap.h"
#include "omnipoint/util/threads.h"

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace omnipoint::geometry {
namespace {

// RGB anchors at the positions k / 255 for k = 0, 8, ..., 248, 255.
constexpr int kAnchors = 33;
constexpr unsigned char kTurbo[kAnchors][3] = {
    {48, 18, 59},   {57, 42, 115},  {64, 64, 162},  {68, 86, 199},  {70, 107, 227}, {70, 128, 246},
    {66, 148, 255}, {55, 168, 250}, {40, 188, 235}, {28, 205, 216}, {24, 221, 194}, {31, 233, 175},
    {50, 242, 152}, {78, 249, 125}, {109, 254, 98}, {139, 255, 75}, {164, 252, 60}, {185, 246, 53},
    {205, 236, 52}, {223, 223, 55}, {238, 207, 58}, {248, 190, 57}, {253, 172, 52}, {254, 150, 43},
    {251, 126, 33}, {244, 102, 23}, {235, 80, 14},  {223, 63, 8},   {208, 47, 5},   {190, 33, 2},
    {169, 22, 1},   {146, 11, 1},   {122, 4, 3}};
constexpr unsigned char kViridis[kAnchors][3] = {
    {68, 1, 84},    {71, 13, 96},   {72, 24, 106},  {72, 35, 116},  {71, 45, 123},  {69, 55, 129},
    {66, 64, 134},  {62, 73, 137},  {59, 82, 139},  {55, 91, 141},  {51, 99, 141},  {47, 107, 142},
    {44, 114, 142}, {41, 122, 142}, {38, 130, 142}, {35, 137, 142}, {33, 145, 140}, {31, 152, 139},
    {31, 160, 136}, {34, 167, 133}, {40, 174, 128}, {50, 182, 122}, {63, 188, 115}, {78, 195, 107},
    {94, 201, 98},  {112, 207, 87}, {132, 212, 75}, {152, 216, 62}, {173, 220, 48}, {194, 223, 35},
    {216, 226, 25}, {236, 229, 27}, {253, 231, 37}};

}  // namespace

at::Tensor apply_colormap(const at::Tensor& values, double low, double high, Colormap map,
                          const at::Tensor& valid) {
  if (!values.defined()) throw std::invalid_argument("apply_colormap: values are undefined");
  if (!std::isfinite(low) || !std::isfinite(high)) {
    throw std::invalid_argument("apply_colormap: low and high must be finite");
  }
  if (valid.defined() && (valid.scalar_type() != at::kBool || valid.sizes() != values.sizes())) {
    throw std::invalid_argument("apply_colormap: valid must be a bool tensor of the values' shape");
  }
  const auto dtype = values.scalar_type() == at::kDouble ? at::kDouble : at::kFloat;
  const at::Tensor v = values.to(at::kCPU, dtype).contiguous();
  const at::Tensor keep = valid.defined() ? valid.to(at::kCPU).contiguous() : at::Tensor();
  auto shape = v.sizes().vec();
  shape.push_back(3);
  at::Tensor rgb = at::empty(shape, v.options());
  const auto& table = map == Colormap::Turbo ? kTurbo : kViridis;
  AT_DISPATCH_FLOATING_TYPES(dtype, "apply_colormap", [&] {
    // Anchor i sits at position min(8 i, 255) / 255; segment i spans anchors i and i + 1.
    scalar_t positions[kAnchors], colors[kAnchors][3];
    for (int i = 0; i < kAnchors; ++i) {
      positions[i] = static_cast<scalar_t>(std::min(8 * i, 255) / 255.0f);
      for (int c = 0; c < 3; ++c) colors[i][c] = static_cast<scalar_t>(table[i][c] / 255.0f);
    }
    const auto offset = static_cast<scalar_t>(low);
    const auto span = static_cast<scalar_t>(high > low ? high - low : 1.0);
    const scalar_t* in = v.data_ptr<scalar_t>();
    const bool* shown = keep.defined() ? keep.data_ptr<bool>() : nullptr;
    scalar_t* out = rgb.data_ptr<scalar_t>();
    util::parallel_for(0, v.numel(), 16384, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) {
        if (!std::isfinite(in[i]) || (shown != nullptr && !shown[i])) {
          out[3 * i] = out[3 * i + 1] = out[3 * i + 2] = 0;
          continue;
        }
        const scalar_t t = std::clamp((in[i] - offset) / span, scalar_t(0), scalar_t(1));
        // The last anchor position <= t (bucketize's), within the 32 segments.
        int segment = std::min(static_cast<int>(t * 255 / 8), kAnchors - 2);
        while (segment > 0 && positions[segment] > t) --segment;
        while (segment < kAnchors - 2 && positions[segment + 1] <= t) ++segment;
        const scalar_t start = positions[segment], stop = positions[segment + 1];
        const scalar_t fraction = (t - start) / (stop - start);
        for (int c = 0; c < 3; ++c) {
          const scalar_t c0 = colors[segment][c], c1 = colors[segment + 1][c];
          out[3 * i + c] = c0 + (c1 - c0) * fraction;
        }
      }
    });
  });
  return rgb.to(values.device(),
                at::isFloatingType(values.scalar_type()) ? values.scalar_type() : at::kFloat);
}

at::Tensor colorize_depth(const at::Tensor& depth, const at::Tensor& valid, Colormap map) {
  if (!depth.defined() || depth.dim() < 2 || !at::isFloatingType(depth.scalar_type())) {
    throw std::invalid_argument(
        "colorize_depth: depth must be a floating tensor of shape (..., H, W)");
  }
  if (valid.defined() && (valid.scalar_type() != at::kBool || valid.sizes() != depth.sizes())) {
    throw std::invalid_argument("colorize_depth: valid must be a bool tensor of the depth's shape");
  }
  const auto dtype = depth.scalar_type() == at::kDouble ? at::kDouble : at::kFloat;
  const at::Tensor d = depth.to(at::kCPU, dtype).contiguous();
  const at::Tensor given = valid.defined() ? valid.to(at::kCPU).contiguous() : at::Tensor();
  at::Tensor unit = at::empty_like(d);
  at::Tensor ok = at::empty(d.sizes(), d.options().dtype(at::kBool));
  const int64_t pixels = depth.size(-2) * depth.size(-1);
  const int64_t maps = pixels == 0 ? 0 : d.numel() / pixels;
  AT_DISPATCH_FLOATING_TYPES(dtype, "colorize_depth", [&] {
    const scalar_t* in = d.data_ptr<scalar_t>();
    const bool* given_ok = given.defined() ? given.data_ptr<bool>() : nullptr;
    scalar_t* out = unit.data_ptr<scalar_t>();
    bool* shown = ok.data_ptr<bool>();
    for (int64_t m = 0; m < maps; ++m) {
      // Disparity of the valid pixels and its range over this map, then a stretch to [0, 1].
      scalar_t lo = std::numeric_limits<scalar_t>::infinity(), hi = -lo;
      for (int64_t i = m * pixels; i < (m + 1) * pixels; ++i) {
        shown[i] = std::isfinite(in[i]) && in[i] > 0 && (given_ok == nullptr || given_ok[i]);
        out[i] = shown[i] ? scalar_t(1) / in[i] : scalar_t(0);
        if (shown[i]) lo = std::min(lo, out[i]), hi = std::max(hi, out[i]);
      }
      const scalar_t range = hi > lo ? hi - lo : scalar_t(1);
      for (int64_t i = m * pixels; i < (m + 1) * pixels; ++i)
        out[i] = shown[i] ? (out[i] - lo) / range : scalar_t(0);
    }
  });
  return apply_colormap(unit, 0.0, 1.0, map, ok).to(depth.device(), depth.scalar_type());
}

}  // namespace omnipoint::geometry
