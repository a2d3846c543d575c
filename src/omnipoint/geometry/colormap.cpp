#include "omnipoint/geometry/colormap.h"

#include <ATen/ATen.h>

#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

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
  const auto dtype = at::isFloatingType(values.scalar_type()) ? values.scalar_type() : at::kFloat;
  const at::Tensor v = values.to(dtype);
  const auto& table = map == Colormap::Turbo ? kTurbo : kViridis;
  std::vector<float> colors, positions;
  for (int i = 0; i < kAnchors; ++i) {
    positions.push_back(std::min(8 * i, 255) / 255.0f);
    for (int c = 0; c < 3; ++c) colors.push_back(table[i][c] / 255.0f);
  }
  const auto opts = v.options();
  const at::Tensor anchors = at::tensor(colors).view({kAnchors, 3}).to(opts);
  const at::Tensor where_at = at::tensor(positions).to(opts);
  const double span = high > low ? high - low : 1.0;
  const at::Tensor t = at::nan_to_num((v - low) / span, 0.0, 1.0, 0.0).clamp(0, 1);
  // Segment i spans [positions[i], positions[i + 1]].
  const at::Tensor segment =
      (at::bucketize(t, where_at, /*out_int32=*/false, /*right=*/true) - 1).clamp(0, kAnchors - 2);
  const at::Tensor start = where_at.index_select(0, segment.reshape(-1)).view(t.sizes());
  const at::Tensor stop = where_at.index_select(0, (segment + 1).reshape(-1)).view(t.sizes());
  const at::Tensor fraction = ((t - start) / (stop - start)).unsqueeze(-1);
  auto shape = t.sizes().vec();
  shape.push_back(3);
  const at::Tensor c0 = anchors.index_select(0, segment.reshape(-1)).view(shape);
  const at::Tensor c1 = anchors.index_select(0, (segment + 1).reshape(-1)).view(shape);
  at::Tensor rgb = c0 + (c1 - c0) * fraction;
  at::Tensor keep = at::isfinite(v);
  if (valid.defined()) keep = keep.logical_and(valid);
  return at::where(keep.unsqueeze(-1), rgb, at::zeros_like(rgb));
}

at::Tensor colorize_depth(const at::Tensor& depth, const at::Tensor& valid, Colormap map) {
  if (!depth.defined() || depth.dim() < 2 || !at::isFloatingType(depth.scalar_type())) {
    throw std::invalid_argument(
        "colorize_depth: depth must be a floating tensor of shape (..., H, W)");
  }
  if (valid.defined() && (valid.scalar_type() != at::kBool || valid.sizes() != depth.sizes())) {
    throw std::invalid_argument("colorize_depth: valid must be a bool tensor of the depth's shape");
  }
  at::Tensor ok = at::isfinite(depth).logical_and(depth > 0);
  if (valid.defined()) ok = ok.logical_and(valid);
  const at::Tensor disparity =
      at::where(ok, 1.0 / at::where(ok, depth, at::ones_like(depth)), at::zeros_like(depth));
  // Per-map range of the valid disparities, then a stretch to [0, 1].
  const at::Tensor flat = disparity.flatten(-2), flat_ok = ok.flatten(-2);
  const double inf = std::numeric_limits<double>::infinity();
  const at::Tensor lo =
      at::where(flat_ok, flat, at::full_like(flat, inf)).amin(-1, true).unsqueeze(-1);
  const at::Tensor hi =
      at::where(flat_ok, flat, at::full_like(flat, -inf)).amax(-1, true).unsqueeze(-1);
  const at::Tensor range = at::where(hi > lo, hi - lo, at::ones_like(hi));
  // Maps without valid pixels have lo = +inf; `ok` is false everywhere there.
  const at::Tensor unit = at::where(ok, (disparity - lo) / range, at::zeros_like(disparity));
  return apply_colormap(unit, 0.0, 1.0, map, ok);
}

}  // namespace omnipoint::geometry
