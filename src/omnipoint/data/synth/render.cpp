#include "omnipoint/data/synth/render.h"

#include <ATen/ATen.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "omnipoint/data/synth/intersect.h"
#include "omnipoint/data/synth/texture.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::data::synth {
namespace {

at::Tensor component(const at::Tensor& t, int64_t i) {
  return t.select(-1, i);
}

at::Tensor dot3(const at::Tensor& a, const at::Tensor& b) {
  return component(a, 0) * component(b, 0) + component(a, 1) * component(b, 1) +
         component(a, 2) * component(b, 2);
}

at::Tensor cross3(const at::Tensor& a, const at::Tensor& b) {
  const auto ax = component(a, 0), ay = component(a, 1), az = component(a, 2);
  const auto bx = component(b, 0), by = component(b, 1), bz = component(b, 2);
  return at::stack({ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx}, -1);
}

at::Tensor normalized(const at::Tensor& v) {
  return v / at::sqrt(dot3(v, v)).clamp_min(1e-20).unsqueeze(-1);
}

at::Tensor vec(const Vec3& v, const at::TensorOptions& options) {
  return at::tensor({v[0], v[1], v[2]}, at::TensorOptions().dtype(at::kDouble)).to(options);
}

// M v for a row-major 3x3 M (transposed: M^T v), elementwise in a fixed order.
at::Tensor rotate(const std::array<std::array<double, 3>, 3>& m, const at::Tensor& v,
                  bool transposed) {
  const auto x = component(v, 0), y = component(v, 1), z = component(v, 2);
  const auto e = [&](int i, int j) { return transposed ? m[j][i] : m[i][j]; };
  return at::stack(
      {e(0, 0) * x + e(0, 1) * y + e(0, 2) * z, e(1, 0) * x + e(1, 1) * y + e(1, 2) * z,
       e(2, 0) * x + e(2, 1) * y + e(2, 2) * z},
      -1);
}

// Sky radiance for world directions: horizon-to-zenith gradient, value-noise clouds
// projected on a cloud layer, the sun's disc; darker below the horizon.
at::Tensor sky_color(const Scene& scene, const at::Tensor& d) {
  const auto options = d.options();
  const auto up = component(d, 2);
  const auto g = at::sqrt(up.clamp(0, 1)).unsqueeze(-1);
  const auto horizon = vec(scene.sky.horizon, options), zenith = vec(scene.sky.zenith, options);
  auto color = horizon * (1 - g) + zenith * g;
  const auto lift = up.clamp_min(0) + 0.12;
  const auto cu = component(d, 0) / lift * 1.5, cv = component(d, 1) / lift * 1.5;
  const auto clouds = fractal_noise(cu, cv, scene.sky.noise_seed, 4);
  const double threshold = 1.0 - 0.6 * scene.sky.cloud_cover;
  const auto cover = ((clouds - threshold) / 0.2).clamp(0, 1) * (up * 8).clamp(0, 1);
  color = color + (vec({0.95, 0.95, 0.97}, options) - color) * cover.unsqueeze(-1);
  for (const auto& light : scene.lights) {
    if (!light.directional) continue;
    const auto towards = dot3(d, vec(light.position, options).expand_as(d));
    color = at::where((towards > 0.9995).unsqueeze(-1), vec({1.0, 0.97, 0.9}, options), color);
  }
  const auto below = (up < 0).unsqueeze(-1);
  return at::where(below, horizon * (0.85 + 0.5 * up.clamp(-0.3, 0)).unsqueeze(-1), color);
}

// Shadow test: 1 where nothing blocks the segment from `from` along `dir` up to `range`.
at::Tensor unoccluded(const PackedScene& ps, const Candidates& candidates, const at::Tensor& from,
                      const at::Tensor& dir, const at::Tensor& range) {
  const auto hit = nearest_hit(ps, candidates, from, dir, 0.0);
  return (hit.t >= range).to(dir.scalar_type());
}

struct Ball {
  Vec3 center;
  double radius;
};

// A ball around points (N, 3), N > 0, from their bounding box (exact min/max reductions).
Ball bounding_ball(const at::Tensor& points) {
  const auto box = at::stack({std::get<0>(points.min(0)), std::get<0>(points.max(0))})
                       .to(at::kCPU, at::kDouble)
                       .contiguous();
  const auto b = box.accessor<double, 2>();
  Ball ball{{0, 0, 0}, 0};
  for (int i = 0; i < 3; ++i) {
    ball.center[i] = 0.5 * (b[0][i] + b[1][i]);
    ball.radius += 0.25 * (b[1][i] - b[0][i]) * (b[1][i] - b[0][i]);
  }
  ball.radius = std::sqrt(ball.radius) * (1 + 1e-6) + 1e-6;
  return ball;
}

// The cone around directions (N, 3), N > 0: its axis and the cosine of its half angle.
Candidates primary_candidates(const PackedScene& ps, const Vec3& origin, const at::Tensor& d) {
  const auto mid = 0.5 * (std::get<0>(d.min(0)) + std::get<0>(d.max(0)));
  const auto axis = normalized(mid.to(at::kDouble));
  const double cos_half = dot3(d.to(at::kDouble), axis.unsqueeze(0)).min().item<double>();
  const auto a = axis.cpu();
  return candidates_in_cone(
      ps, origin, {a[0].item<double>(), a[1].item<double>(), a[2].item<double>()}, cos_half - 1e-6);
}

struct Shaded {
  at::Tensor rgb;     // (n, 3) linear radiance in [0, 1]
  at::Tensor t;       // (n) 0 where no hit
  at::Tensor mask;    // (n)
  at::Tensor normal;  // (n, 3) camera frame, 0 where no hit
};

Shaded shade(const Scene& scene, const PackedScene& ps, const at::Tensor& rays,
             const at::Tensor& valid, const RenderOptions& options) {
  const auto opt = rays.options();
  const auto forward = at::tensor({0.0, 0.0, 1.0}, at::TensorOptions().dtype(at::kDouble)).to(opt);
  const auto cam = at::where(valid.unsqueeze(-1), rays, forward);
  const auto d = rotate(scene.pose.rotation, cam, false);
  const auto origin = vec(scene.pose.position, opt).unsqueeze(0);
  const auto hit = nearest_hit(ps, primary_candidates(ps, scene.pose.position, d), origin, d, 1e-6);
  const auto mask = (hit.t <= options.max_distance) & valid;

  // Surfaces, textures and lighting only for the rays that hit something, compacted.
  const auto idx = at::nonzero(mask).squeeze(-1);
  const auto dh = d.index_select(0, idx);
  const auto th = hit.t.index_select(0, idx);
  const auto ph = origin + th.unsqueeze(-1) * dh;
  const auto surface = surface_at(ps, ph, hit.primitive.index_select(0, idx));
  const auto facing = (dot3(surface.normal, dh) > 0).unsqueeze(-1);
  const auto nh = at::where(facing, -surface.normal, surface.normal);
  const auto base = albedo(scene, surface.material, surface.uv);
  const auto lift = (1e-3 + 1e-4 * th).unsqueeze(-1);
  const auto from = ph + nh * lift;
  auto irradiance = vec(scene.ambient, opt) * (0.8 + 0.2 * component(nh, 2)).unsqueeze(-1);
  const Ball origins = idx.numel() > 0 ? bounding_ball(from) : Ball{};
  if (options.ambient_occlusion && idx.numel() > 0) {
    // Three short rays at 60 degrees from the normal, 120 degrees apart around it.
    const auto helper =
        at::where((component(nh, 2).abs() < 0.9).unsqueeze(-1), vec({0, 0, 1}, opt).expand_as(nh),
                  vec({1, 0, 0}, opt).expand_as(nh));
    const auto tangent = normalized(cross3(nh, helper)), bitangent = cross3(nh, tangent);
    const double reach = 0.6, up = 0.5, out = std::sqrt(0.75), half = 0.5, sixty = std::sqrt(0.75);
    const auto near = candidates_within(ps, origins.center, origins.radius, reach);
    auto open = at::zeros_like(th);
    for (const auto& side :
         {tangent, -half * tangent + sixty * bitangent, -half * tangent - sixty * bitangent})
      open = open + unoccluded(ps, near, from, nh * up + side * out, at::full_like(th, reach));
    irradiance = irradiance * (0.45 + 0.55 * open / 3).unsqueeze(-1);
  }
  for (const auto& light : scene.lights) {
    at::Tensor l, falloff, range;
    if (light.directional) {
      l = vec(light.position, opt).expand_as(ph);
      falloff = at::ones_like(th);
      range = at::full_like(th, std::numeric_limits<double>::infinity());
    } else {
      const auto to_light = vec(light.position, opt) - ph;
      const auto dist2 = dot3(to_light, to_light);
      range = at::sqrt(dist2);
      l = to_light / range.unsqueeze(-1);
      falloff = 1.0 / dist2.clamp_min(0.25);
    }
    auto lambert = dot3(nh, l).clamp_min(0) * falloff;
    if (options.shadows && light.casts_shadows && idx.numel() > 0) {
      const auto lit = at::nonzero(lambert > 0).squeeze(-1);
      const auto blockers = candidates_near_path(ps, origins.center, origins.radius, light.position,
                                                 light.directional);
      const auto vis = unoccluded(ps, blockers, from.index_select(0, lit), l.index_select(0, lit),
                                  range.index_select(0, lit));
      lambert = lambert.index_copy(0, lit, lambert.index_select(0, lit) * vis);
    }
    irradiance = irradiance + lambert.unsqueeze(-1) * vec(light.color, opt);
  }
  auto radiance = base * irradiance;
  if (scene.fog_distance > 0) {
    const auto haze = (th / (th + scene.fog_distance)).unsqueeze(-1);
    radiance = radiance + (vec(scene.sky.horizon, opt) - radiance) * haze;
  }
  const auto sky = at::nonzero(mask.logical_not()).squeeze(-1);
  auto rgb = at::zeros_like(d).index_copy(0, idx, radiance);
  rgb = rgb.index_copy(0, sky, sky_color(scene, d.index_select(0, sky)));
  rgb = at::where(valid.unsqueeze(-1), rgb, at::zeros_like(rgb));
  const auto normal = at::zeros_like(d).index_copy(0, idx, rotate(scene.pose.rotation, nh, true));
  return {rgb, at::where(mask, hit.t, at::zeros_like(hit.t)), mask, normal};
}

}  // namespace

Render render_scene(const Scene& scene, const at::Tensor& rays, const at::Tensor& valid,
                    const RenderOptions& options) {
  if (rays.dim() != 3 || rays.size(2) != 3 || !at::isFloatingType(rays.scalar_type()))
    throw std::invalid_argument("render_scene: rays must be a floating (H, W, 3) tensor");
  if (valid.sizes() != rays.sizes().slice(0, 2) || valid.scalar_type() != at::kBool)
    throw std::invalid_argument("render_scene: valid must be a bool (H, W) tensor");
  if (scene.materials.empty() || options.tile_size <= 0 || !(options.max_distance > 0))
    throw std::invalid_argument(
        "render_scene: the scene has no materials, or tile size or max distance <= 0");
  const int64_t height = rays.size(0), width = rays.size(1);
  const auto ps = pack_scene(scene, rays.options());
  auto rgb = at::empty({height, width, 3}, rays.options());
  auto distance = at::empty({height, width}, rays.options());
  auto mask = at::empty({height, width}, valid.options());
  auto normals = at::empty({height, width, 3}, rays.options());
  const int64_t tile = options.tile_size;
  const int64_t tiles_x = (width + tile - 1) / tile, tiles_y = (height + tile - 1) / tile;
  const auto work = [&](int64_t begin, int64_t end) {
    for (int64_t i = begin; i < end; ++i) {
      const int64_t y0 = (i / tiles_x) * tile, x0 = (i % tiles_x) * tile;
      const int64_t h = std::min(tile, height - y0), w = std::min(tile, width - x0);
      const auto window = [&](const at::Tensor& t) { return t.narrow(0, y0, h).narrow(1, x0, w); };
      const auto out = shade(scene, ps, window(rays).reshape({h * w, 3}),
                             window(valid).reshape({h * w}), options);
      window(rgb).copy_(out.rgb.view({h, w, 3}));
      window(distance).copy_(out.t.view({h, w}));
      window(mask).copy_(out.mask.view({h, w}));
      window(normals).copy_(out.normal.view({h, w, 3}));
    }
  };
  // CPU: threads take whole tiles (each tile's ops then run single-threaded inside);
  // CUDA: tiles run in order, each already parallel on the device.
  if (rays.is_cuda())
    work(0, tiles_x * tiles_y);
  else
    util::parallel_for(0, tiles_x * tiles_y, 1, work);

  // Display encoding: clamp and a square-root gamma (an exact IEEE operation).
  const auto encoded = at::floor(at::sqrt(rgb.clamp(0, 1)) * 255 + 0.5).to(at::kByte);
  Render result;
  result.image = encoded;
  result.distance = distance;
  result.depth = distance * rays.select(-1, 2);
  result.normals = normals;
  result.mask = mask;
  return result;
}

}  // namespace omnipoint::data::synth
