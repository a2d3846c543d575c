// Forward time of the OmniPoint network (random weights) with each condition combination, and
// the cost of the conditioning itself (ray-map / sparse-depth encoders and the Gaussian
// splatting at the ViT input size). Results and commands: docs/PERFORMANCE.md.
//
// Configuration: ViT-S/14 backbone (layers [2,5,8,11]) with MoGe-2's published decoder widths
// [384,256,128,64,32] for the neck and the ray, distance and mask heads, scale MLP
// [384,384,384,1], conditioning defaults (r = 7, 64 hidden channels). Image 480×640, batch 1,
// 1,200 tokens (30×40 grid), a pinhole ray map, 1,000 sparse samples (the paper's evaluation).
#include <ATen/ATen.h>
#include <ATen/Parallel.h>
#include <benchmark/benchmark.h>
#include <c10/core/InferenceMode.h>

#include <string>

#include "omnipoint/model/omnipoint_model.h"

namespace {

using namespace omnipoint::model;

constexpr int64_t kHeight = 480, kWidth = 640, kNumTokens = 1200;

OmniPointConfig vit_s_config() {
  const std::string dims = R"("dim_res_blocks": [384, 256, 128, 64, 32],
      "resamplers": ["conv_transpose", "conv_transpose", "conv_transpose", "bilinear"])";
  const auto head = [&](int channels) {
    return R"({"dim_in": [384, 256, 128, 64, 32], "num_res_blocks": [0, 1, 1, 1, 0],
               "dim_out": [null, null, null, null, )" +
           std::to_string(channels) + "], " + dims + "}";
  };
  return OmniPointConfig::from_json_text(
      R"({"encoder": {"backbone": "dinov2_vits14", "intermediate_layers": [2, 5, 8, 11], "dim_out": 384},
          "neck": {"dim_in": [386, 2, 2, 2, 2], "num_res_blocks": [0, 2, 2, 2, 0], "dim_out": null, )" +
      dims + R"(},
          "ray_head": )" +
      head(3) + R"(, "distance_head": )" + head(1) + R"(, "mask_head": )" + head(1) + R"(,
          "scale_head": {"dims": [384, 384, 384, 1]}})");
}

OmniPointInputs inputs(bool intrinsics, bool depth) {
  at::manual_seed(0);
  OmniPointInputs in{at::rand({1, 3, kHeight, kWidth})};
  if (intrinsics) {
    const at::Tensor u = (at::arange(kWidth, at::kFloat) + 0.5 - kWidth / 2.0) / 500.0;
    const at::Tensor v = (at::arange(kHeight, at::kFloat) + 0.5 - kHeight / 2.0) / 500.0;
    const auto grid = at::meshgrid({v, u}, "ij");
    const at::Tensor rays = at::stack({grid[1], grid[0], at::ones_like(grid[0])}, 0);
    in.rays = (rays / rays.norm(2, {0}, true)).unsqueeze(0);
  }
  if (depth) {
    const at::Tensor index = at::randperm(kHeight * kWidth).narrow(0, 0, 1000);
    in.sparse_depth = at::zeros({1, kHeight * kWidth});
    in.sparse_depth.index_put_({0, index}, 1.0 + 9.0 * at::rand({1000}));
    in.sparse_depth = in.sparse_depth.view({1, kHeight, kWidth});
  }
  return in;
}

// range(0): 0 image only, 1 +K, 2 +D, 3 +K+D.
void BM_OmniPointForward(benchmark::State& state) {
  at::set_num_threads(2);
  c10::InferenceMode inference;
  OmniPointModel model(vit_s_config());
  model->eval();
  const OmniPointInputs in = inputs(state.range(0) & 1, state.range(0) & 2);
  model->forward(in, kNumTokens);  // warm-up
  for (auto _ : state) benchmark::DoNotOptimize(model->forward(in, kNumTokens).points);
}
BENCHMARK(BM_OmniPointForward)
    ->DenseRange(0, 3)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

// The conditioning alone: the token offset for +K+D.
void BM_ConditionTokens(benchmark::State& state) {
  at::set_num_threads(2);
  c10::InferenceMode inference;
  OmniPointModel model(vit_s_config());
  const OmniPointInputs in = inputs(true, true);
  const TokenGrid grid = token_grid(kHeight, kWidth, kNumTokens);
  for (auto _ : state) benchmark::DoNotOptimize(model->condition_tokens(in, grid).offset);
}
BENCHMARK(BM_ConditionTokens)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
