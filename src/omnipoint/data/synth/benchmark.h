#pragma once
// A versioned synthetic set definition (benchmarks/*.json): an evaluation benchmark
// (synthetic_v1.json, docs/EVALUATION.md) or a pre-rendered training pool (training_pool_v1.json,
// docs/TRAINING.md). Per split a sample count (at most 100,000), camera specs and scene kinds;
// per named set ("main", "final", "train") a base seed. Sample i of split k (k in file order) is
// rendered with
//   camera = cameras[i mod C],  scene = scenes[(i div C) mod S],  seed = set seed + 100000·k + i
// so every camera sees every scene kind and the two sets share no scene. Everything is fixed
// by the file: the same definition and set give byte-identical samples (synthesize.h).
#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/render.h"
#include "omnipoint/data/synth/scene.h"

namespace omnipoint::data::synth {

struct BenchmarkSample {
  std::string folder;  // "<split>/<index, zero-padded to 4 digits or those of count - 1>"
  std::string split;
  camera::Camera camera;
  SceneKind scene;
  std::uint64_t seed;
};

struct BenchmarkPlan {
  std::string name;
  int64_t version = 0;
  RenderOptions render;
  std::vector<BenchmarkSample> samples;
};

// Parses a definition (JSON text; `what` names it in errors) and lists the samples of `set`,
// at most `per_split_limit` per split when > 0 (the first ones, so a reduced run is a prefix of
// the full one). Bad JSON, missing or mistyped fields, bad camera specs or scene kinds and an
// unknown set -> std::invalid_argument naming the definition and the field.
BenchmarkPlan plan_benchmark(const std::string& json_text, const std::string& what,
                             const std::string& set, int64_t per_split_limit = 0);

}  // namespace omnipoint::data::synth
