// omnipoint synth: renders procedural scenes through a camera into sample folders, or a whole
// versioned benchmark definition (benchmarks/*.json) into OUT/<split>/<index>.
#include <CLI/CLI.hpp>

#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <stdexcept>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "cli/device.h"
#include "cli/threads.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/benchmark.h"
#include "omnipoint/data/synth/camera_path.h"
#include "omnipoint/data/synth/kitti_raw_drive.h"
#include "omnipoint/data/synth/rig_render.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/staged_folder.h"

namespace omnipoint::cli {
namespace {

struct SynthArgs {
  std::string camera, scene = "indoor", out, device = "cpu", benchmark, set = "main";
  std::uint64_t seed = 0;
  int count = 1;
  int64_t per_split = 0;
  bool no_shadows = false, no_ao = false, core_files = false;
  // --kitti-raw: a driving log with LiDAR sweeps (data/synth/kitti_raw_drive.h).
  bool kitti_raw = false;
  int64_t held_out = 0;
  geometry::LidarPattern lidar;
  std::vector<double> lidar_elevation{-24.9, 2.0};
  double lidar_range = 120.0;
  std::string shard_text = "0/1";
  std::array<int64_t, 2> shard{0, 1};
  int threads = 0;  // 0: every core
  // --rig: every camera of a rig at its body pose, frames + truth (data/synth/rig_render.h).
  std::string rig, body_axes = "camera";
  double yaw_deg = 0;
  bool lidar_sweep = false;
  // --path: a camera path through one scene (data/synth/camera_path.h).
  bool path = false;
  double path_step = 0.05, path_yaw_deg = 1.0;
};

data::synth::SynthOptions synth_options(const SynthArgs& args) {
  data::synth::SynthOptions options;
  options.render.shadows = !args.no_shadows;
  options.render.ambient_occlusion = !args.no_ao;
  options.device = parse_device(args.device);
  return options;
}

// A set definition (a benchmark or a training pool) into OUT/<split>/<index>. Its render
// settings are part of the definition; --no-shadows / --no-ao do not apply. Each sample is
// written into a staging folder (io::StagedFolder) and renamed into place when complete, so a
// folder that exists is whole: an interrupted run resumes where it stopped (existing folders are
// kept, what a killed run left half-written is removed), and --shard K/N lets N processes share
// the work. Prints one line per sample and the total time.
void render_definition(const SynthArgs& args) {
  namespace fs = std::filesystem;
  const auto plan = data::synth::plan_benchmark(io::read_file(args.benchmark), args.benchmark,
                                                args.set, args.per_split);
  auto options = synth_options(args);
  options.render = plan.render;
  const auto files =
      args.core_files ? data::synth::SynthFiles::kCore : data::synth::SynthFiles::kAll;
  const auto start = std::chrono::steady_clock::now();
  int64_t rendered = 0, kept = 0;
  for (size_t i = static_cast<size_t>(args.shard[0]); i < plan.samples.size();
       i += static_cast<size_t>(args.shard[1])) {
    const auto& sample = plan.samples[i];
    const fs::path folder = fs::path(args.out) / sample.folder;
    if (fs::is_directory(folder)) {
      ++kept;
      continue;
    }
    io::StagedFolder staged(folder);
    data::synth::write_synth_sample(
        staged.path().string(),
        data::synth::synthesize(sample.scene, sample.seed, sample.camera, options), files);
    staged.commit();
    ++rendered;
    std::cout << folder.string() << "\n";
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cerr << "synth: " << plan.name << " v" << plan.version << " set " << args.set << ": "
            << rendered << " samples rendered in " << seconds << " s";
  if (kept > 0) std::cerr << ", " << kept << " already there";
  std::cerr << "\n";
}

// --count training frames and --held-out frames as a KITTI raw root with LiDAR sweeps.
void render_kitti_raw(const SynthArgs& args) {
  data::synth::KittiRawDriveOptions options;
  options.camera = io::read_camera(args.camera);
  options.scene = data::synth::parse_scene_kind(args.scene);
  options.seed = args.seed;
  options.frames = args.count;
  options.held_out = args.held_out;
  options.lidar = args.lidar;
  options.lidar.min_elevation_deg = args.lidar_elevation[0];
  options.lidar.max_elevation_deg = args.lidar_elevation[1];
  options.lidar_range = args.lidar_range;
  options.synth = synth_options(args);
  const auto start = std::chrono::steady_clock::now();
  const data::synth::KittiRawDriveSummary summary =
      data::synth::write_kitti_raw_drive(args.out, options);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << args.out << "\n";
  std::cerr << "synth: KITTI raw root " << args.out << ": " << summary.train_frames.size()
            << " training and " << summary.test_frames.size() << " held-out frames, "
            << summary.returns << " LiDAR returns, " << summary.label_density * 100
            << " % of the pixels labelled, in " << seconds << " s\n";
}

// --count frames of a rig (--rig): OUT/rig.json, OUT/frames/<frame>/<camera>.png [lidar.bin],
// OUT/truth/<frame>/<camera>/; with --path the body moves through one scene; resumes where an
// earlier run stopped.
void render_rig_frames(const SynthArgs& args) {
  if (!args.camera.empty() || !args.benchmark.empty() || args.kitti_raw)
    throw std::invalid_argument(
        "--rig renders the rig's cameras: no --camera, --benchmark or "
        "--kitti-raw with it");
  data::synth::RigFramesOptions options;
  options.rig = args.rig;
  options.scene = data::synth::parse_scene_kind(args.scene);
  options.seed = args.seed;
  options.frames = args.count;
  options.render.body_axes = data::synth::parse_body_axes(args.body_axes);
  options.render.yaw = args.yaw_deg * M_PI / 180.0;
  options.render.synth = synth_options(args);
  options.render.lidar = args.lidar_sweep;
  options.render.lidar_pattern = args.lidar;
  options.render.lidar_pattern.min_elevation_deg = args.lidar_elevation[0];
  options.render.lidar_pattern.max_elevation_deg = args.lidar_elevation[1];
  options.render.lidar_range = args.lidar_range;
  options.path = args.path;
  options.path_step = args.path_step;
  options.path_yaw_deg = args.path_yaw_deg;
  const auto start = std::chrono::steady_clock::now();
  const data::synth::RigFramesSummary summary = data::synth::write_rig_frames(
      args.out, options, [](const std::string& frame) { std::cout << frame << "\n"; });
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cerr << "synth: rig " << args.rig << ": " << summary.rendered << " frame(s) rendered";
  if (summary.kept > 0) std::cerr << ", " << summary.kept << " already there";
  if (args.lidar_sweep) std::cerr << ", " << summary.lidar_points << " LiDAR returns";
  std::cerr << " in " << seconds << " s; predict with: omnipoint predict --rig " << args.out
            << "/rig.json " << args.out << "/frames" << (args.path ? " --sequence" : "")
            << " --out PREDICTIONS\n";
}

// --count frames of a camera path through the scene of --scene and --seed.
void render_camera_path(const SynthArgs& args) {
  data::synth::CameraPathOptions options;
  if (!args.camera.empty()) options.camera = io::read_camera(args.camera);
  options.scene = data::synth::parse_scene_kind(args.scene);
  options.seed = args.seed;
  options.frames = args.count;
  options.step = args.path_step;
  options.yaw_step_deg = args.path_yaw_deg;
  options.synth = synth_options(args);
  const auto start = std::chrono::steady_clock::now();
  const std::vector<std::string> frames = data::synth::write_camera_path(args.out, options);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::cout << args.out << "\n";
  std::cerr << "synth: camera path " << args.out << ": " << frames.size() << " frames of "
            << args.scene << " scene " << args.seed << " (" << args.out << "/frames for predict "
            << "--sequence, " << args.out << "/truth for eval --sequence), in " << seconds
            << " s\n";
}

// "K/N" with 0 <= K < N.
std::array<int64_t, 2> parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  try {
    if (slash != std::string::npos) {
      size_t used_k = 0, used_n = 0;
      const std::string k_text = text.substr(0, slash), n_text = text.substr(slash + 1);
      const int64_t k = std::stoll(k_text, &used_k), n = std::stoll(n_text, &used_n);
      if (used_k == k_text.size() && used_n == n_text.size() && n >= 1 && k >= 0 && k < n)
        return {k, n};
    }
  } catch (const std::exception&) {
  }
  throw std::invalid_argument("--shard " + text + ": expected K/N with 0 <= K < N");
}

void add_camera_path_options(CLI::App* cmd, SynthArgs& args) {
  cmd->add_flag("--path", args.path,
                "write a camera path through one scene (--scene, --seed): --count frames moving "
                "--path-step metres forward and turning --path-yaw degrees per frame, as "
                "OUT/frames/*.png (predict --sequence) and OUT/truth/<frame>/ (samples with "
                "their poses; eval --sequence) (default camera PINHOLE 128 96 80 80 64 48); with "
                "--rig the rig's body moves so through the one scene of --seed (predict --rig "
                "--sequence)");
  cmd->add_option("--path-step", args.path_step, "--path: metres per frame along the view")
      ->capture_default_str();
  cmd->add_option("--path-yaw", args.path_yaw_deg, "--path: degrees per frame, turning left")
      ->capture_default_str();
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
  cmd->add_option("--benchmark,--definition", args->benchmark,
                  "render a set definition (benchmarks/*.json: a benchmark or a training pool) "
                  "instead of --camera/--scene; resumes where an earlier run stopped");
  cmd->add_option("--set", args->set, "the definition's set: main | final | train ...")
      ->capture_default_str();
  cmd->add_option("--per-split", args->per_split,
                  "definition: at most N samples per split (0: all)")
      ->capture_default_str();
  cmd->add_option("--shard", args->shard_text,
                  "definition: render samples K, K+N, K+2N, ... (N processes share a set)")
      ->capture_default_str();
  cmd->add_flag("--core-files", args->core_files,
                "write only image.png, distance.npy, mask.png and meta.json (what training reads)");
  cmd->add_option("--out", args->out, "output folder")->required();
  cmd->add_option("--device", args->device, "cpu | cuda")->capture_default_str();
  cmd->add_flag("--no-shadows", args->no_shadows, "skip shadow rays (faster)");
  cmd->add_flag("--no-ao", args->no_ao, "skip ambient-occlusion rays (faster)");
  cmd->add_flag("--kitti-raw", args->kitti_raw,
                "write --count training and --held-out frames of --scene through --camera (a "
                "PINHOLE) as a KITTI raw root with LiDAR sweeps and split lists into --out "
                "(docs/TRAINING.md)");
  cmd->add_option("--held-out", args->held_out, "--kitti-raw: held-out frames (test_files.txt)")
      ->capture_default_str();
  cmd->add_option("--lidar-beams", args->lidar.beams,
                  "--kitti-raw, --rig --lidar: the LiDAR's beams")
      ->capture_default_str();
  cmd->add_option(
         "--lidar-elevation", args->lidar_elevation,
         "--kitti-raw, --rig --lidar: the beams' elevations MIN MAX in degrees (up positive)")
      ->expected(2)
      ->capture_default_str();
  cmd->add_option("--lidar-azimuth-steps", args->lidar.azimuth_steps,
                  "--kitti-raw, --rig --lidar: firings per revolution")
      ->capture_default_str();
  cmd->add_option("--lidar-range", args->lidar_range, "--kitti-raw, --rig --lidar: metres")
      ->capture_default_str();
  cmd->add_option("--rig", args->rig,
                  "render --count frames of a rig file's cameras (scene seed + k each) into "
                  "OUT/frames/<frame>/<camera>.png with their truth in OUT/truth (docs/RIG.md)");
  cmd->add_option("--body-axes", args->body_axes,
                  "--rig: the body's axes on the scene's viewpoint: camera (x right, y down, z "
                  "forward) | vehicle (x forward, y left, z up)")
      ->capture_default_str();
  cmd->add_option("--yaw", args->yaw_deg, "--rig: the body turned about the up axis, degrees")
      ->capture_default_str();
  cmd->add_flag("--lidar", args->lidar_sweep,
                "--rig: cast the rig's LiDAR (--lidar-beams ...) into each frame's lidar.bin");
  add_camera_path_options(cmd, *args);
  add_threads_option(cmd, &args->threads);
  cmd->callback([args] {
    use_threads(args->threads);
    if (args->path && args->rig.empty()) {
      if (!args->benchmark.empty() || args->kitti_raw)
        throw std::invalid_argument("--path: not with --benchmark or --kitti-raw");
      render_camera_path(*args);
      return;
    }
    if (!args->rig.empty()) {
      render_rig_frames(*args);
      return;
    }
    if (args->kitti_raw) {
      if (!args->benchmark.empty())
        throw std::invalid_argument("--kitti-raw and --benchmark: choose one");
      if (args->camera.empty()) throw std::invalid_argument("--kitti-raw needs --camera");
      render_kitti_raw(*args);
      return;
    }
    if (!args->benchmark.empty()) {
      args->shard = parse_shard(args->shard_text);
      render_definition(*args);
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
      data::synth::write_synth_sample(
          folder, data::synth::synthesize(kind, seed, camera, options),
          args->core_files ? data::synth::SynthFiles::kCore : data::synth::SynthFiles::kAll);
      std::cout << folder << "\n";
    }
  });
}

}  // namespace omnipoint::cli
