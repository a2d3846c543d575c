// Camera fitting (camera/fit.h) on exact ray maps of three camera kinds at 640x480 and
// 4000x3000 (12 MP): fit_camera_auto, and fit_camera_model of the true model. The ray maps
// are made before the timed loop.
#include <ATen/ATen.h>
#include <benchmark/benchmark.h>

#include <string>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/fit.h"

namespace {

using namespace omnipoint::camera;

// The specs at 640 pixels wide, resized to range(0) pixels wide.
const char* const kSpecs[] = {"PINHOLE 640 480 525 523 319.5 241",
                              "OPENCV_FISHEYE 640 480 180 180 320 240 0.02 -0.005 0 0",
                              "EQUIRECTANGULAR 640 320"};

Camera camera_of(const benchmark::State& state) {
  const Camera camera = parse_camera(kSpecs[state.range(1)]);
  const int64_t width = state.range(0);
  return camera.resized(width, camera.height() * width / camera.width());
}

// range(0): width; range(1): 0 pinhole, 1 fisheye, 2 panorama.
void BM_FitCameraAuto(benchmark::State& state) {
  const Camera truth = camera_of(state);
  const Rays map = truth.ray_map(at::kFloat);
  for (auto _ : state) {
    const CameraFit fit = fit_camera_auto(truth.width(), truth.height(), map.rays, map.valid);
    benchmark::DoNotOptimize(fit.residual.median_deg);
  }
  state.SetLabel(truth.model_name() + " " + std::to_string(truth.width()) + "x" +
                 std::to_string(truth.height()));
}

// A predicted ray map is not exact: every ray turned by ~0.3 degrees at random (about what the
// bundled model's rays are off by), so "auto" scores each candidate instead of stopping at the
// first exact one. range(0), range(1) as above.
void BM_FitCameraAutoNoisy(benchmark::State& state) {
  const Camera truth = camera_of(state);
  const Rays map = truth.ray_map(at::kFloat);
  at::manual_seed(0);
  const at::Tensor turned = map.rays + 0.005 * at::randn(map.rays.sizes());
  const at::Tensor rays = turned / turned.norm(2, -1, true);
  for (auto _ : state) {
    const CameraFit fit = fit_camera_auto(truth.width(), truth.height(), rays, map.valid);
    benchmark::DoNotOptimize(fit.residual.median_deg);
  }
  state.SetLabel(truth.model_name() + " " + std::to_string(truth.width()) + "x" +
                 std::to_string(truth.height()));
}

void BM_FitCameraModel(benchmark::State& state) {
  const Camera truth = camera_of(state);
  const Rays map = truth.ray_map(at::kFloat);
  for (auto _ : state) {
    const CameraFit fit =
        fit_camera_model(truth.model_name(), truth.width(), truth.height(), map.rays, map.valid);
    benchmark::DoNotOptimize(fit.residual.median_deg);
  }
  state.SetLabel(truth.model_name() + " " + std::to_string(truth.width()) + "x" +
                 std::to_string(truth.height()));
}

void sizes_and_kinds(benchmark::internal::Benchmark* bench) {
  for (const int64_t width : {640, 4000})
    for (const int64_t kind : {0, 1, 2}) bench->Args({width, kind});
  bench->Unit(benchmark::kMillisecond)->UseRealTime()->MinTime(0.5);
}
BENCHMARK(BM_FitCameraAuto)->Apply(sizes_and_kinds);
BENCHMARK(BM_FitCameraAutoNoisy)->Apply(sizes_and_kinds);
BENCHMARK(BM_FitCameraModel)->Apply(sizes_and_kinds);

}  // namespace
