#include "omnipoint/data/synth/texture.h"

#include <ATen/ATen.h>

#include <vector>

namespace omnipoint::data::synth {
namespace {

constexpr int64_t kLow32 = 0xffffffff;
constexpr int64_t kAvalanche = 0x45d9f3b;
constexpr int64_t kPrimeX = 73856093, kPrimeY = 19349663;

// A 32-bit integer finaliser (values kept below 2^32, products below 2^59).
at::Tensor avalanche(at::Tensor h) {
  h = at::bitwise_and(at::bitwise_xor(h, at::bitwise_right_shift(h, 16)) * kAvalanche, kLow32);
  h = at::bitwise_and(at::bitwise_xor(h, at::bitwise_right_shift(h, 16)) * kAvalanche, kLow32);
  return at::bitwise_xor(h, at::bitwise_right_shift(h, 16));
}

at::Tensor fractional_part(const at::Tensor& x) {
  return x - at::floor(x);
}
at::Tensor as_long(const at::Tensor& x) {
  return at::floor(x).to(at::kLong);
}

at::Tensor blend(const at::Tensor& a, const at::Tensor& b, const at::Tensor& t) {
  return a + (b - a) * t;
}

}  // namespace

at::Tensor lattice_hash(const at::Tensor& ix, const at::Tensor& iy, std::uint32_t seed,
                        const at::Tensor& like) {
  const auto x = at::bitwise_and(ix, kLow32) * kPrimeX, y = at::bitwise_and(iy, kLow32) * kPrimeY;
  const auto h = at::bitwise_xor(at::bitwise_xor(x, y), static_cast<int64_t>(seed));
  return avalanche(at::bitwise_and(h, kLow32)).to(like.scalar_type()) * (1.0 / 4294967296.0);
}

at::Tensor value_noise(const at::Tensor& u, const at::Tensor& v, std::uint32_t seed) {
  const auto fu = at::floor(u), fv = at::floor(v);
  const auto tu = u - fu, tv = v - fv;
  const auto su = tu * tu * (3 - 2 * tu), sv = tv * tv * (3 - 2 * tv);
  const auto iu = fu.to(at::kLong), iv = fv.to(at::kLong);
  const auto h00 = lattice_hash(iu, iv, seed, u), h10 = lattice_hash(iu + 1, iv, seed, u);
  const auto h01 = lattice_hash(iu, iv + 1, seed, u), h11 = lattice_hash(iu + 1, iv + 1, seed, u);
  return blend(blend(h00, h10, su), blend(h01, h11, su), sv);
}

at::Tensor fractal_noise(const at::Tensor& u, const at::Tensor& v, std::uint32_t seed,
                         int octaves) {
  auto sum = at::zeros_like(u);
  double amplitude = 1.0, total = 0.0, frequency = 1.0;
  for (int o = 0; o < octaves; ++o) {
    sum = sum + amplitude * value_noise(u * frequency, v * frequency, seed + 101u * o);
    total += amplitude;
    amplitude *= 0.5;
    frequency *= 2.0;
  }
  return sum / total;
}

at::Tensor albedo(const Scene& scene, const at::Tensor& material, const at::Tensor& uv) {
  const auto options = uv.options();
  std::vector<int64_t> patterns;
  std::vector<double> color_a, color_b, scales;
  bool used[kNumPatterns] = {};
  for (const auto& m : scene.materials) {
    patterns.push_back(static_cast<int64_t>(m.pattern));
    color_a.insert(color_a.end(), m.color_a.begin(), m.color_a.end());
    color_b.insert(color_b.end(), m.color_b.begin(), m.color_b.end());
    scales.push_back(m.scale);
    used[static_cast<int>(m.pattern)] = true;
  }
  const auto count = static_cast<int64_t>(scene.materials.size());
  const auto f64 = at::TensorOptions().dtype(at::kDouble);
  const auto pattern =
      at::tensor(patterns, f64.dtype(at::kLong)).to(options.device()).index_select(0, material);
  const auto a = at::tensor(color_a, f64).reshape({count, 3}).to(options).index_select(0, material);
  const auto b = at::tensor(color_b, f64).reshape({count, 3}).to(options).index_select(0, material);
  const auto scale = at::tensor(scales, f64).to(options).index_select(0, material);

  // Each material's pattern is offset in texture space so equal patterns differ.
  const auto offset = material.to(options.dtype()) * 37.17;
  const auto um = uv.select(-1, 0) + offset, vm = uv.select(-1, 1) + offset * 0.61;
  const auto u = um / scale, v = vm / scale;
  const std::uint32_t seed = scene.texture_seed;
  const auto one = at::ones_like(u);

  auto mix = at::zeros_like(u);   // 0 -> colour a, 1 -> colour b
  auto shade = at::ones_like(u);  // per-cell brightness variation
  const auto put = [&](Pattern p, const at::Tensor& f, const at::Tensor& s) {
    const auto here = pattern == static_cast<int64_t>(p);
    mix = at::where(here, f, mix);
    shade = at::where(here, s, shade);
  };
  if (used[static_cast<int>(Pattern::kNoise)])
    put(Pattern::kNoise, fractal_noise(u * 4, v * 4, seed, 3), one);
  if (used[static_cast<int>(Pattern::kStripes)])
    put(Pattern::kStripes, (fractional_part(u) >= 0.5).to(u.scalar_type()), one);
  if (used[static_cast<int>(Pattern::kTiles)]) {
    const auto grout = (fractional_part(u) < 0.05) | (fractional_part(v) < 0.05);
    const auto tile = 0.8 + 0.35 * lattice_hash(as_long(u), as_long(v), seed + 7, u);
    put(Pattern::kTiles, grout.to(u.scalar_type()), at::where(grout, one, tile));
  }
  if (used[static_cast<int>(Pattern::kBricks)]) {
    const auto rows = v * 3;
    const auto row = at::floor(rows);
    const auto shifted = u + 0.5 * (row - 2 * at::floor(row * 0.5));
    const auto mortar = (fractional_part(shifted) < 0.04) | (fractional_part(rows) < 0.12);
    const auto brick = 0.75 + 0.5 * lattice_hash(as_long(shifted), row.to(at::kLong), seed + 11, u);
    put(Pattern::kBricks, mortar.to(u.scalar_type()), at::where(mortar, one, brick));
  }
  if (used[static_cast<int>(Pattern::kWood)]) {
    const auto across = v * 6;
    const auto plank = at::floor(across);
    const auto plank_id = plank.to(at::kLong);
    const auto stagger = lattice_hash(plank_id, plank_id * 0 + 3, seed + 13, u);
    const auto along = u + stagger;
    const auto grain = value_noise(along * 1.5, across * 5, seed + 17);
    const auto rings = (2 * fractional_part(grain * 6 + stagger) - 1).abs();
    const auto board = 0.8 + 0.35 * lattice_hash(as_long(along), plank_id, seed + 19, u);
    const auto seam = (fractional_part(across) < 0.04) | (fractional_part(along) < 0.01);
    put(Pattern::kWood, rings, at::where(seam, 0.5 * one, board));
  }
  if (used[static_cast<int>(Pattern::kChecker)]) {
    const auto parity = at::bitwise_and(as_long(u) + as_long(v), 1);
    put(Pattern::kChecker, parity.to(u.scalar_type()), one);
  }
  if (used[static_cast<int>(Pattern::kFacade)]) {
    const auto fu = fractional_part(u), fv = fractional_part(v);
    const auto window = (fu > 0.22) & (fu < 0.78) & (fv > 0.28) & (fv < 0.82);
    const auto lit = 0.45 + 0.9 * lattice_hash(as_long(u), as_long(v), seed + 23, u);
    const auto wall = 0.9 + 0.2 * value_noise(u * 6, v * 6, seed + 29);
    put(Pattern::kFacade, window.to(u.scalar_type()), at::where(window, lit, wall));
  }
  // Fine surface detail at fixed metric scales: texture density encodes distance.
  const auto detail = (0.86 + 0.28 * value_noise(um * 5, vm * 5, seed + 31)) *
                      (0.93 + 0.14 * value_noise(um * 40, vm * 40, seed + 37));
  const auto color = blend(a, b, mix.unsqueeze(-1)) * (shade * detail).unsqueeze(-1);
  return color.clamp(0, 1);
}

}  // namespace omnipoint::data::synth
