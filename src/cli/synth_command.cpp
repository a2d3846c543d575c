// omnipoint synth: renders procedural scenes through a camera into sample folders.
#include <CLI/CLI.hpp>

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/synthesize.h"

namespace omnipoint::cli {

void add_synth_command(CLI::App& app) {
  struct Args {
    std::string camera, scene = "indoor", out, device = "cpu";
    std::uint64_t seed = 0;
    int count = 1;
    bool no_shadows = false, no_ao = false;
  };
  auto args = std::make_shared<Args>();
  auto* cmd = app.add_subcommand(
      "synth",
      "Render procedural metric scenes through a camera: one folder per sample (seed N+i) "
      "with image.png, distance.npy, depth.npy, rays.npy, normals.npy, mask.png, meta.json");
  cmd->add_option("--camera", args->camera, "camera spec (COLMAP line, JSON, or file)")->required();
  cmd->add_option("--scene", args->scene, "indoor | outdoor | object")->capture_default_str();
  cmd->add_option("--seed", args->seed, "seed of the first sample")->capture_default_str();
  cmd->add_option("--count", args->count, "number of samples")->capture_default_str();
  cmd->add_option("--out", args->out, "output folder")->required();
  cmd->add_option("--device", args->device, "cpu | cuda")->capture_default_str();
  cmd->add_flag("--no-shadows", args->no_shadows, "skip shadow rays (faster)");
  cmd->add_flag("--no-ao", args->no_ao, "skip ambient-occlusion rays (faster)");
  cmd->callback([args] {
    const auto camera = camera::parse_camera(args->camera);
    const auto kind = data::synth::parse_scene_kind(args->scene);
    if (args->count < 1) throw std::invalid_argument("--count " + std::to_string(args->count) + ": expected >= 1");
    data::synth::SynthOptions options;
    options.render.shadows = !args->no_shadows;
    options.render.ambient_occlusion = !args->no_ao;
    if (args->device != "cpu" && args->device != "cuda")
      throw std::invalid_argument("--device " + args->device + ": expected cpu or cuda");
    options.device = args->device == "cuda" ? at::Device(at::kCUDA) : at::Device(at::kCPU);
    for (int i = 0; i < args->count; ++i) {
      const std::uint64_t seed = args->seed + static_cast<std::uint64_t>(i);
      char name[32];
      std::snprintf(name, sizeof name, "%06llu", static_cast<unsigned long long>(seed));
      const auto folder = (std::filesystem::path(args->out) / name).string();
      data::synth::write_synth_sample(folder, data::synth::synthesize(kind, seed, camera, options));
      std::cout << folder << "\n";
    }
  });
}

}  // namespace omnipoint::cli
