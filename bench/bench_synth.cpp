// Synthetic sample rendering: scene generation + ray casting + shading for a 512x256
// panorama and a 640x480 pinhole image, per scene kind (results in docs/PERFORMANCE.md).
#include <ATen/ATen.h>
#include <benchmark/benchmark.h>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/synthesize.h"

namespace {
using omnipoint::data::synth::SceneKind;

void render(benchmark::State& state, const char* spec, SceneKind kind, bool shadows_and_ao) {
  const auto camera = omnipoint::camera::parse_camera(spec);
  omnipoint::data::synth::SynthOptions options;
  options.render.shadows = shadows_and_ao;
  options.render.ambient_occlusion = shadows_and_ao;
  std::uint64_t seed = 0;
  for (auto _ : state) {
    auto sample = omnipoint::data::synth::synthesize(kind, seed++ % 4, camera, options);
    benchmark::DoNotOptimize(sample.sample.distance.data_ptr());
  }
  state.counters["pixels/s"] = benchmark::Counter(double(camera.width() * camera.height()),
                                                  benchmark::Counter::kIsIterationInvariantRate);
}

constexpr const char* kPanorama = "EQUIRECTANGULAR 512 256";
constexpr const char* kPinhole = "PINHOLE 640 480 500 500 320 240";

}  // namespace

BENCHMARK_CAPTURE(render, panorama_indoor, kPanorama, SceneKind::kIndoor, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(render, panorama_outdoor, kPanorama, SceneKind::kOutdoor, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(render, panorama_object, kPanorama, SceneKind::kObject, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(render, pinhole_indoor, kPinhole, SceneKind::kIndoor, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(render, pinhole_outdoor, kPinhole, SceneKind::kOutdoor, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(render, pinhole_object, kPinhole, SceneKind::kObject, true)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
BENCHMARK_CAPTURE(render, pinhole_indoor_no_shadows_no_ao, kPinhole, SceneKind::kIndoor, false)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();
