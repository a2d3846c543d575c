// Writing every output file of one prediction (predict::write_prediction_outputs with
// --outputs all) for a synthetic prediction: a pinhole view of a bumpy wall with a step and a
// hole, a random image. Each file's time is a counter in ms (camera.json's timing_ms.files),
// next to the whole call's. range(2) is the thread count (`omnipoint predict` uses every core):
// the files are written concurrently, one per thread.
#include <ATen/ATen.h>
#include <ATen/Parallel.h>
#include <benchmark/benchmark.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <string>

#include "omnipoint/camera/camera.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predictor.h"

namespace {

using namespace omnipoint;
namespace fs = std::filesystem;

// range(0) x range(1): the image size; range(2): threads.
void BM_WriteAllOutputs(benchmark::State& state) {
  const int64_t width = state.range(0), height = state.range(1);
  const int threads_before = at::get_num_threads();
  at::set_num_threads(static_cast<int>(state.range(2)));
  const camera::Camera camera =
      camera::parse_camera("PINHOLE " + std::to_string(width) + " " + std::to_string(height) + " " +
                           std::to_string(0.8 * width) + " " + std::to_string(0.8 * width) + " " +
                           std::to_string(0.5 * width) + " " + std::to_string(0.5 * height));
  const camera::Rays map = camera.ray_map(at::kFloat);
  const at::Tensor column = at::linspace(0, 1, width).view({1, width});
  const at::Tensor row = at::linspace(0, 1, height).view({height, 1});
  // A wall 4 m away with bumps, 1 m nearer on the left third, and a round hole.
  const at::Tensor distance =
      4.0 + 0.2 * at::sin(40 * column) * at::cos(30 * row) - (column < 1.0 / 3).to(at::kFloat);
  const at::Tensor hole = (column - 0.7).square() + (row - 0.5).square() < 0.01;
  const at::Tensor mask = map.valid & ~hole;
  predict::Prediction p =
      predict::prediction_from_geometry(map.rays, distance.to(at::kFloat), mask);
  p.fitted_camera = camera;
  at::manual_seed(0);
  const at::Tensor image = at::randint(0, 256, {height, width, 3}, at::kByte);
  predict::OutputOptions options;
  options.files = predict::parse_output_list("all");
  const fs::path folder = fs::temp_directory_path() / "bench_outputs" / "prediction";

  nlohmann::json files;
  double writing = 0;
  for (auto _ : state) {
    writing += predict::write_prediction_outputs(folder.string(), image, p, options);
    const auto json = nlohmann::json::parse(io::read_file((folder / "camera.json").string()));
    files = json["timing_ms"]["files"];
    files["valid_points"] = json["timing_ms"]["valid_points"];
  }
  for (const auto& [name, ms] : files.items()) state.counters[name] = ms.get<double>();
  state.counters["writing_ms"] = writing / static_cast<double>(state.iterations());
  fs::remove_all(folder.parent_path());
  at::set_num_threads(threads_before);
}
BENCHMARK(BM_WriteAllOutputs)
    ->ArgNames({"width", "height", "threads"})
    ->Args({640, 480, 1})
    ->Args({640, 480, 2})
    ->Args({4000, 3000, 1})
    ->Args({4000, 3000, 2})
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
