// Sparse-depth densification and simulation, normals, PLY output (docs/PERFORMANCE.md).
#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <benchmark/benchmark.h>

#include <filesystem>

#include "omnipoint/camera/camera.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/geometry/sparse_depth.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/io/ply.h"

using namespace omnipoint;

namespace {

// Sparse depth of `count` samples on a (batch, height, width) map.
at::Tensor sparse_map(int64_t batch, int64_t height, int64_t width, int64_t count) {
  auto g = at::make_generator<at::CPUGeneratorImpl>(1);
  auto dense = at::rand({batch, height, width}, g, at::kFloat) * 10 + 1;
  return geometry::sample_uniform(dense, at::ones_like(dense, at::kBool), count, g).depth;
}

void BM_SplatSparseDepth(benchmark::State& state) {
  const int64_t batch = state.range(0), height = state.range(1), width = state.range(2),
                count = state.range(3);
  const at::Tensor sparse = sparse_map(batch, height, width, count);
  for (auto _ : state) benchmark::DoNotOptimize(geometry::splat_sparse_depth(sparse).smooth);
}
BENCHMARK(BM_SplatSparseDepth)
    ->Args({1, 518, 518, 1000})
    ->Args({8, 518, 518, 1000})
    ->Args({1, 1080, 1920, 2000})
    ->Args({1, 480, 640, 307200})
    ->Unit(benchmark::kMillisecond);

void BM_SampleLidar(benchmark::State& state) {
  auto camera = camera::centred_pinhole(90.0, 1920, 1080);
  const auto rays = camera.ray_map(at::kFloat);
  const at::Tensor dense = at::full({1080, 1920}, 5.0f);
  for (auto _ : state)
    benchmark::DoNotOptimize(geometry::sample_lidar(dense, rays.valid, rays.rays).depth);
}
BENCHMARK(BM_SampleLidar)->Unit(benchmark::kMillisecond);

void BM_NormalsFromPointMap(benchmark::State& state) {
  auto camera = camera::centred_pinhole(90.0, 1920, 1080);
  const at::Tensor points = camera.ray_map(at::kFloat).rays * 3.0f;
  for (auto _ : state) benchmark::DoNotOptimize(geometry::normals_from_point_map(points).normals);
}
BENCHMARK(BM_NormalsFromPointMap)->Unit(benchmark::kMillisecond);

void BM_WritePly(benchmark::State& state) {
  auto g = at::make_generator<at::CPUGeneratorImpl>(2);
  const at::Tensor points = at::randn({state.range(0), 3}, g, at::kFloat);
  const at::Tensor colors = at::randint(0, 256, {state.range(0), 3}, g, at::kByte);
  const auto path = (std::filesystem::temp_directory_path() / "omnipoint_bench.ply").string();
  for (auto _ : state) io::write_ply(path, points, colors);
  std::filesystem::remove(path);
}
BENCHMARK(BM_WritePly)->Arg(1 << 20)->Unit(benchmark::kMillisecond);

}  // namespace
