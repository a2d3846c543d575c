// omnipoint synth: renders procedural scenes through a camera into sample folders, or a whole
// versioned benchmark definition (benchmarks/*.json) into OUT/<split>/<index>.
#include <CLI/CLI.hpp>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "cli/device.h"
#include "cli/threads.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/benchmark.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/camera_file.h"

namespace omnipoint::cli {
namespace {

struct SynthArgs {
  std::string camera, scene = "indoor", out, device = "cpu", benchmark, set = "main";
  std::uint64_t seed = 0;
  int count = 1;
  int64_t per_split = 0;
  bool no_shadows = false, no_ao = false;
  int threads = 0;  // 0: every core
};

data::synth::SynthOptions synth_options(const SynthArgs& args) {
  data::synth::SynthOptions options;
  options.render.shadows = !args.no_shadows;
  options.render.ambient_occlusion = !args.no_ao;
  options.device = parse_device(args.device);
  return options;
}

// The benchmark's render settings are part of its definition; --no-shadows / --no-ao do not
// apply. Prints one line per sample and the total time.
void render_benchmark(const SynthArgs& args) {
  const auto plan = data::synth::plan_benchmark(io::read_file(args.benchmark), args.benchmark,
                                                args.set, args.per_split);
  auto options = synth_options(args);
  options.render = plan.render;
  const auto start = std::chrono::steady_clock::now();
  for (const auto& sample : plan.samples) {
    const auto folder = (std::filesystem::path(args.out) / sample.folder).string();
    data::synth::write_synth_sample(
        folder, data::synth::synthesize(sample.scene, sample.seed, sample.camera, options));
    std::cout << folder << "\n";
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cerr << "synth: " << plan.name << " v" << plan.version << " set " << args.set << ": "
            << plan.samples.size() << " samples in " << seconds << " s\n";
}

}  // namespace

void add_synth_command(CLI::App& app) {
  auto args = std::make_shared<SynthArgs>();
  auto* cmd = app.add_subcommand(
      "synth",
      "Render procedural metric scenes through a camera: one folder per sample (seed N+i) "
      "with image.png, distance.npy, depth.npy, rays.npy, normals.npy, mask.png, meta.json; "
      "or a benchmark definition with --benchmark");
  cmd->add_option("--camera", args->camera, "camera spec (COLMAP line, JSON, or file)");
  cmd->add_option("--scene", args->scene, "indoor | outdoor | object")->capture_default_str();
  cmd->add_option("--seed", args->seed, "seed of the first sample")->capture_default_str();
  cmd->add_option("--count", args->count, "number of samples")->capture_default_str();
  cmd->add_option("--benchmark", args->benchmark,
                  "render a benchmark definition (benchmarks/*.json) instead of --camera/--scene");
  cmd->add_option("--set", args->set, "benchmark set: main | final")->capture_default_str();
  cmd->add_option("--per-split", args->per_split, "benchmark: at most N samples per split (0: all)")
      ->capture_default_str();
  cmd->add_option("--out", args->out, "output folder")->required();
  cmd->add_option("--device", args->device, "cpu | cuda")->capture_default_str();
  cmd->add_flag("--no-shadows", args->no_shadows, "skip shadow rays (faster)");
  cmd->add_flag("--no-ao", args->no_ao, "skip ambient-occlusion rays (faster)");
  add_threads_option(cmd, &args->threads);
  cmd->callback([args] {
    use_threads(args->threads);
    if (!args->benchmark.empty()) {
      render_benchmark(*args);
      return;
    }
    if (args->camera.empty())
      throw std::invalid_argument("--camera is required (or --benchmark FILE)");
    const auto camera = io::read_camera(args->camera);
    const auto kind = data::synth::parse_scene_kind(args->scene);
    if (args->count < 1)
      throw std::invalid_argument("--count " + std::to_string(args->count) + ": expected >= 1");
    const auto options = synth_options(*args);
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
