// Ray-map generation (Camera::ray_map, float32 output) for typical camera sizes.
#include <ATen/ATen.h>
#include <benchmark/benchmark.h>

#include <string>

#include "omnipoint/camera/camera.h"

namespace {

void ray_map(benchmark::State& state, const std::string& spec) {
  const auto camera = omnipoint::camera::parse_camera(spec);
  for (auto _ : state) {
    auto map = camera.ray_map(at::kFloat);
    benchmark::DoNotOptimize(map.rays.data_ptr<float>());
  }
  state.SetItemsProcessed(state.iterations() * camera.width() * camera.height());
}

BENCHMARK_CAPTURE(ray_map, equirectangular_4096x2048, std::string("EQUIRECTANGULAR 4096 2048"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ray_map, opencv_1920x1080,
                  std::string("OPENCV 1920 1080 1400 1402 960.5 540.5 -0.28 0.09 0.0008 -0.0005"))
    ->Unit(benchmark::kMillisecond);
// A fisheye over 180 degrees (1-D Newton unprojection), and the unified models (closed form;
// MEI with distortion adds the 2-D solve).
BENCHMARK_CAPTURE(ray_map, opencv_fisheye_1920x1080,
                  std::string("OPENCV_FISHEYE 1920 1080 560.2 559.8 960.5 540.5 0.031 -0.0094 "
                              "0.0012 -0.00011"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ray_map, mei_1920x1080,
                  std::string("MEI 1920 1080 1180.4 1179.6 960.5 540.5 1.42 -0.217 0.094 0.00037 "
                              "-0.00052"))
    ->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(ray_map, double_sphere_1920x1080,
                  std::string("DOUBLE_SPHERE 1920 1080 420.3 420.1 960.5 540.5 -0.2 0.55"))
    ->Unit(benchmark::kMillisecond);

}  // namespace
