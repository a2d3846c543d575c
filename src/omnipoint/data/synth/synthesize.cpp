#include "omnipoint/data/synth/synthesize.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>

#include "omnipoint/io/npy.h"

namespace omnipoint::data::synth {

SynthSample synthesize(SceneKind kind, std::uint64_t seed, const camera::Camera& camera,
                       const SynthOptions& options) {
  return render_sample(make_scene(kind, seed), camera, options);
}

SynthSample render_sample(Scene scene, const camera::Camera& camera, const SynthOptions& options) {
  const auto rays = camera.ray_map(at::TensorOptions().dtype(at::kFloat).device(options.device));
  const Render render = render_scene(scene, rays.rays, rays.valid, options.render);
  const auto cpu = [](const at::Tensor& t) { return t.to(at::kCPU).contiguous(); };
  Sample sample{camera, cpu(render.image).to(at::kFloat) / 255.0,
                cpu(render.distance).to(at::kFloat), cpu(render.mask), true};
  return SynthSample{std::move(sample), cpu(render.depth).to(at::kFloat),
                     cpu(rays.rays).to(at::kFloat), cpu(render.normals).to(at::kFloat),
                     std::move(scene)};
}

std::string scene_meta_json(const Scene& scene) {
  constexpr double kDegrees = 180.0 / 3.14159265358979323846;
  const auto& p = scene.pose;
  nlohmann::json pose = {
      {"position", p.position},
      {"rotation", p.rotation},
      {"yaw_deg", p.yaw * kDegrees},
      {"pitch_deg", p.pitch * kDegrees},
      {"roll_deg", p.roll * kDegrees},
      {"convention",
       "X_world = rotation * X_camera + position; world x east, y north, z up, metres"}};
  nlohmann::json meta = {
      {"scene", scene_kind_name(scene.kind)}, {"seed", scene.seed}, {"pose", pose}};
  return meta.dump();
}

void write_synth_sample(const std::string& folder, const SynthSample& s, SynthFiles files) {
  write_sample(folder, s.sample, scene_meta_json(s.scene));
  if (files == SynthFiles::kCore) return;
  const std::filesystem::path dir(folder);
  io::write_npy((dir / "depth.npy").string(), s.depth);
  io::write_npy((dir / "rays.npy").string(), s.rays);
  io::write_npy((dir / "normals.npy").string(), s.normals);
}

}  // namespace omnipoint::data::synth
