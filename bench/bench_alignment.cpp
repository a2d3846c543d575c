// Exact weighted-L1 alignment: the fast solvers against MoGe's exhaustive anchor search on
// evaluation-like data (4,096 = 64×64 subsample samples, weights 1/g, 3 % gross outliers),
// and the whole metric protocol on the fixture's largest instance.
#include <ATen/ATen.h>
#include <benchmark/benchmark.h>

#include <string>

#include "omnipoint/eval/metrics.h"
#include "omnipoint/geometry/alignment.h"
#include "omnipoint/io/npy.h"

namespace {

using namespace omnipoint;

struct DepthSamples {
  at::Tensor pred, gt, weight;
};

DepthSamples depth_samples(int64_t n) {
  at::manual_seed(42);
  DepthSamples s;
  s.gt = at::rand({n}) * 20 + 1.5;
  s.pred = 0.6 * s.gt.pow(0.95) + 0.3 + 0.05 * s.gt * at::randn({n});
  const at::Tensor outlier = at::rand({n}) < 0.03;
  s.pred = at::where(outlier, s.pred * 3, s.pred);
  s.weight = 1 / s.gt;
  return s;
}

struct PointSamples {
  at::Tensor pred, gt, weight;
};

PointSamples point_samples(int64_t n) {
  at::manual_seed(43);
  PointSamples s;
  const at::Tensor depth = at::rand({n, 1}) * 20 + 1.5;
  const at::Tensor uv = at::rand({n, 2}) * 1.4 - 0.7;
  s.gt = at::cat({uv * depth, depth}, 1);
  s.pred = 0.7 * s.gt + at::tensor({0.1f, -0.2f, 0.8f}) + 0.03 * depth * at::randn({n, 3});
  s.pred = at::where(at::rand({n, 1}) < 0.03, s.pred * 2.5, s.pred);
  s.weight = 1 / s.gt.norm(2, -1);
  return s;
}

void BM_DepthAffineFast(benchmark::State& state) {
  const DepthSamples s = depth_samples(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(geometry::fit_affine_l1(s.pred, s.gt, s.weight).scale);
}
BENCHMARK(BM_DepthAffineFast)->Arg(256)->Arg(1024)->Arg(4096)->Unit(benchmark::kMillisecond);

void BM_DepthAffineBruteForce(benchmark::State& state) {
  const DepthSamples s = depth_samples(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(geometry::fit_affine_l1_brute_force(s.pred, s.gt, s.weight).scale);
}
BENCHMARK(BM_DepthAffineBruteForce)->Arg(256)->Arg(1024)->Arg(4096)->Unit(benchmark::kMillisecond);

void BM_DepthAffineFastBatch8(benchmark::State& state) {
  const DepthSamples s = depth_samples(8 * state.range(0));
  const at::Tensor pred = s.pred.view({8, -1}), gt = s.gt.view({8, -1}), w = s.weight.view({8, -1});
  for (auto _ : state) benchmark::DoNotOptimize(geometry::fit_affine_l1(pred, gt, w).scale);
}
BENCHMARK(BM_DepthAffineFastBatch8)->Arg(4096)->Unit(benchmark::kMillisecond);

void BM_PointsAnchoredPruned(benchmark::State& state) {
  const PointSamples s = point_samples(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(geometry::fit_points_affine_l1_anchored(s.pred, s.gt, s.weight).scale);
}
BENCHMARK(BM_PointsAnchoredPruned)->Arg(256)->Arg(1024)->Arg(4096)->Unit(benchmark::kMillisecond);

void BM_PointsAnchoredBruteForce(benchmark::State& state) {
  const PointSamples s = point_samples(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(
        geometry::fit_points_affine_l1_anchored_brute_force(s.pred, s.gt, s.weight).scale);
}
BENCHMARK(BM_PointsAnchoredBruteForce)
    ->Arg(256)
    ->Arg(1024)
    ->Arg(4096)
    ->Unit(benchmark::kMillisecond);

void BM_PointsAffineGlobal(benchmark::State& state) {
  const PointSamples s = point_samples(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(geometry::fit_points_affine_l1(s.pred, s.gt, s.weight).scale);
}
BENCHMARK(BM_PointsAffineGlobal)->Arg(4096)->Unit(benchmark::kMillisecond);

void BM_PointsScaleZShiftTruncated(benchmark::State& state) {
  const PointSamples s = point_samples(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(
        geometry::fit_points_scale_z_shift_l1_truncated(s.pred, s.gt, s.weight, 1.0).scale);
}
BENCHMARK(BM_PointsScaleZShiftTruncated)->Arg(1024)->Unit(benchmark::kMillisecond);

void BM_ScaleMedian(benchmark::State& state) {
  const DepthSamples s = depth_samples(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(geometry::fit_scale_l1(s.pred, s.gt, s.weight).scale);
}
BENCHMARK(BM_ScaleMedian)->Arg(4096)->Unit(benchmark::kMillisecond);

void BM_ScaleTruncated(benchmark::State& state) {
  const DepthSamples s = depth_samples(state.range(0));
  for (auto _ : state)
    benchmark::DoNotOptimize(geometry::fit_scale_l1_truncated(s.pred, s.gt, s.weight, 0.1).scale);
}
BENCHMARK(BM_ScaleTruncated)->Arg(4096)->Unit(benchmark::kMillisecond);

void BM_ComputeMetricsFixtureInstance3(benchmark::State& state) {
  const std::string dir = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge_metrics_a/instance_3/";
  eval::GroundTruth gt;
  gt.depth = io::read_npy(dir + "gt_depth.npy");
  gt.points = io::read_npy(dir + "gt_points.npy");
  gt.mask = io::read_npy(dir + "mask.npy").to(at::kBool);
  eval::Prediction pred;
  pred.depth = io::read_npy(dir + "pred_depth.npy");
  pred.points = io::read_npy(dir + "pred_points.npy");
  for (auto _ : state) benchmark::DoNotOptimize(eval::compute_metrics(pred, gt).entries.size());
}
BENCHMARK(BM_ComputeMetricsFixtureInstance3)->Unit(benchmark::kMillisecond);

}  // namespace
