// Perspective-to-Any: a 1 MP pinhole RGB-D sample rendered into a 2048×1024 panorama and a
// 1024×1024 fisheye (docs/PERFORMANCE.md); A2P view extraction and stitching.
#include <ATen/ATen.h>
#include <benchmark/benchmark.h>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/augment/p2a.h"
#include "omnipoint/augment/virtual_camera.h"
#include "omnipoint/augment/warp.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/geometry/points.h"

using namespace omnipoint;

namespace {

struct Source {
  camera::Camera camera = camera::centred_pinhole(90, 1152, 864);  // 0.995 MP
  at::Tensor image, distance, mask;
};

// A slanted, bumpy surface 2–6 m away with a random texture: every pixel labelled.
const Source& source() {
  static const Source s = [] {
    Source out;
    const auto rays = out.camera.ray_map(at::kFloat).rays;
    const at::Tensor x = rays.select(-1, 0), y = rays.select(-1, 1);
    const at::Tensor depth = 4.0 + 1.5 * x + 0.3 * at::sin(20 * x) * at::cos(15 * y);
    out.distance = geometry::distance_from_planar_depth(depth, rays).distance;
    out.mask = out.distance > 0;
    out.image = at::rand({out.camera.height(), out.camera.width(), 3}, at::kFloat);
    return out;
  }();
  return s;
}

void run_p2a(benchmark::State& state, const camera::Camera& target) {
  const Source& s = source();
  augment::P2AOptions options;
  options.supersample = state.range(0);
  const augment::VirtualView view{target, augment::rotation_from_angles(10, 5, 0), {}};
  for (auto _ : state) {
    benchmark::DoNotOptimize(
        augment::perspective_to_any(s.camera, s.image, s.distance, s.mask, view, options).mask);
  }
}

void BM_P2A_Panorama2048(benchmark::State& state) {
  run_p2a(state, camera::Camera("EQUIRECTANGULAR", 2048, 1024, {}));
}
BENCHMARK(BM_P2A_Panorama2048)
    ->Arg(0)
    ->Arg(1)
    ->Arg(2)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_P2A_Fisheye1024(benchmark::State& state) {
  run_p2a(state, augment::fisheye_with_fov("DOUBLE_SPHERE", 1024, 1024, 200, {-0.1, 0.6}));
}
BENCHMARK(BM_P2A_Fisheye1024)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// A2P around the teacher: a 518×518 view out of a 2048×1024 panorama and its stitching back.
void BM_A2P_ExtractAndStitch(benchmark::State& state) {
  const camera::Camera wide("EQUIRECTANGULAR", 2048, 1024, {});
  const at::Tensor image = at::rand({1024, 2048, 3}, at::kFloat);
  const auto view = augment::make_perspective_view(80, 30, 10, 518, 518);
  const augment::TeacherPrediction prediction{
      {}, at::full({518, 518}, 3.0f), at::ones({518, 518}, at::kBool)};
  for (auto _ : state) {
    benchmark::DoNotOptimize(augment::extract_view(wide, image, view).image);
    benchmark::DoNotOptimize(augment::stitch_view(wide, view, prediction).mask);
  }
}
BENCHMARK(BM_A2P_ExtractAndStitch)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
