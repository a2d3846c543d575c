#pragma once
// One synthetic training sample: a procedural scene (its kind and seed fix the scene and the
// camera pose) rendered through any camera, in the dataset format of data/sample.h plus the
// extra ground truth only a renderer has. The sample folder holds, beside the core files,
//   depth.npy (H, W) planar depth, rays.npy (H, W, 3), normals.npy (H, W, 3) camera frame,
//   and meta.json gains "scene", "seed" and "pose" (see docs/DATASET.md).
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/render.h"
#include "omnipoint/data/synth/scene.h"

namespace omnipoint::data::synth {

struct SynthOptions {
  RenderOptions render;
  at::Device device = at::kCPU;  // where the rays are cast
};

struct SynthSample {
  Sample sample;       // image, distance (0 on sky/invalid), mask, camera; metric = true
  at::Tensor depth;    // (H, W) float32 planar depth (camera z), 0 where mask is false
  at::Tensor rays;     // (H, W, 3) float32 unit rays, 0 where the camera is invalid
  at::Tensor normals;  // (H, W, 3) float32 unit camera-frame normals facing the camera
  Scene scene;
};

SynthSample synthesize(SceneKind kind, std::uint64_t seed, const camera::Camera& camera,
                       const SynthOptions& options = {});
// The same for a scene already made (its pose moved: a camera path, data/synth/camera_path.h).
SynthSample render_sample(Scene scene, const camera::Camera& camera,
                          const SynthOptions& options = {});

// meta.json fields describing the scene: {"scene", "seed", "pose": {...}} as JSON text.
std::string scene_meta_json(const Scene& scene);

// Which files write_synth_sample writes: all of them, or only what training reads (the core
// files of data/sample.h: a training pool at a quarter of the disk space).
enum class SynthFiles { kAll, kCore };

// Writes the sample folder (core files + depth, rays, normals unless kCore; scene meta).
void write_synth_sample(const std::string& folder, const SynthSample& sample,
                        SynthFiles files = SynthFiles::kAll);

}  // namespace omnipoint::data::synth
