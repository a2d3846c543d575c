// Forward time of MoGe-2 networks (random weights) on this machine, and how close the ViT
// blocks come to the machine's GEMM throughput. Results and commands: docs/PERFORMANCE.md.
//
// Configurations: MoGe-2's published ViT-L decoder (neck/head dims [C,256,128,64,32],
// neck res blocks [0,2,2,2,0], heads [0,1,1,1,0], points + mask + normal heads, scale MLP
// [C,C,C,1], intermediate layers [5,11,17,23]); ViT-B and ViT-S use the same decoder with
// C = their width and layers [2,5,8,11]. Image 480×640 (4:3), batch 1, 2 intra-op threads;
// one untimed warm-up run, then one timed run (a ViT-L forward takes seconds here). The
// `bf16` argument runs under the inference path's bf16 autocast (model/precision.h).
#include <ATen/ATen.h>
#include <ATen/Parallel.h>
#include <benchmark/benchmark.h>
#include <c10/core/InferenceMode.h>
#include <nlohmann/json.hpp>

#include <sys/resource.h>

#include <fstream>
#include <string>

#include "omnipoint/io/process_memory.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/precision.h"

namespace {

using namespace omnipoint::model;

nlohmann::json conv_stack(int64_t width, int64_t level0_in, bool neck, nlohmann::json out) {
  return {{"dim_in",
           neck ? nlohmann::json{level0_in, 2, 2, 2, 2} : nlohmann::json{width, 256, 128, 64, 32}},
          {"dim_out", out},
          {"dim_res_blocks", {width, 256, 128, 64, 32}},
          {"num_res_blocks", neck ? nlohmann::json{0, 2, 2, 2, 0} : nlohmann::json{0, 1, 1, 1, 0}},
          {"res_block_in_norm", "none"},
          {"res_block_hidden_norm", "none"},
          {"resamplers", {"conv_transpose", "conv_transpose", "conv_transpose", "bilinear"}}};
}

MoGe2Config moge2_config(const std::string& backbone) {
  const DinoV2Config vit = DinoV2Config::hub(backbone);
  const int64_t c = vit.embed_dim;
  const nlohmann::json layers =
      vit.depth == 24 ? nlohmann::json{5, 11, 17, 23} : nlohmann::json{2, 5, 8, 11};
  const nlohmann::json none = nullptr;
  return MoGe2Config::from_json(
      {{"encoder", {{"backbone", backbone}, {"intermediate_layers", layers}, {"dim_out", c}}},
       {"neck", conv_stack(c, c + 2, true, none)},
       {"points_head", conv_stack(c, c, false, {none, none, none, none, 3})},
       {"mask_head", conv_stack(c, c, false, {none, none, none, none, 1})},
       {"normal_head", conv_stack(c, c, false, {none, none, none, none, 3})},
       {"scale_head", {{"dims", {c, c, c, 1}}}},
       {"remap_output", "exp"},
       {"num_tokens_range", {1200, 3600}}});
}

const char* kBackbones[] = {"dinov2_vits14", "dinov2_vitb14", "dinov2_vitl14"};

at::Tensor test_image() {
  return at::rand({1, 3, 480, 640});
}

// Peak resident memory of one benchmark: Linux's high-water mark (VmHWM), reset at its start
// by writing 5 to /proc/self/clear_refs. Memory the allocator kept from earlier benchmarks
// counts too: run one configuration per process for clean figures.
void reset_peak_memory() {
  std::ofstream("/proc/self/clear_refs") << "5";
}
// CPU seconds of the whole process (all threads): with other jobs on the machine, wall time
// depends on the load; CPU time much less so.
double process_cpu_seconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + 1e-6 * static_cast<double>(t.tv_usec);
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

double peak_memory_mb() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;  // kB
  }
  return 0;
}

Precision precision_of(const benchmark::State& state, int64_t arg) {
  return state.range(arg) != 0 ? Precision::kBFloat16 : Precision::kFloat32;
}

// GEMM throughput of the machine: a ViT-L MLP-sized product (2400×1024 · 1024×4096), in fp32
// or bf16.
void BM_Gemm(benchmark::State& state) {
  const at::ScalarType dtype = state.range(0) != 0 ? at::kBFloat16 : at::kFloat;
  const at::Tensor a = at::randn({2400, 1024}).to(dtype), b = at::randn({1024, 4096}).to(dtype);
  at::mm(a, b);
  const double cpu_start = process_cpu_seconds();
  for (auto _ : state) benchmark::DoNotOptimize(at::mm(a, b));
  state.counters["cpu_s"] =
      benchmark::Counter(process_cpu_seconds() - cpu_start, benchmark::Counter::kAvgIterations);
  state.counters["GFLOP/s"] =
      benchmark::Counter(2.0 * 2400 * 1024 * 4096, benchmark::Counter::kIsIterationInvariantRate,
                         benchmark::Counter::kIs1000);
}

// The transformer blocks alone (tokens prepared once): FLOPs per block 24·N·C² + 4·N²·C.
void BM_VitBlocks(benchmark::State& state) {
  c10::InferenceMode inference;
  MoGe2Model model(moge2_config(kBackbones[state.range(0)]));
  model->eval();
  const AutocastScope autocast(precision_of(state, 2), c10::DeviceType::CPU);
  auto& encoder = *model->encoder;
  const at::Tensor image = test_image();
  const TokenGrid grid = token_grid(image.size(2), image.size(3), state.range(1));
  const at::Tensor tokens = encoder.backbone->prepare_tokens(encoder.preprocess(image, grid));
  const auto& layers = encoder.config().intermediate_layers;
  encoder.backbone->intermediate_layers(tokens, layers);  // warm-up
  const double cpu_start = process_cpu_seconds();
  for (auto _ : state)
    benchmark::DoNotOptimize(encoder.backbone->intermediate_layers(tokens, layers));
  state.counters["cpu_s"] =
      benchmark::Counter(process_cpu_seconds() - cpu_start, benchmark::Counter::kAvgIterations);
  const double n = static_cast<double>(tokens.size(1)), c = static_cast<double>(tokens.size(2));
  const double flops = (24 * n * c * c + 4 * n * n * c) * static_cast<double>(layers.back() + 1);
  state.counters["GFLOP/s"] = benchmark::Counter(
      flops, benchmark::Counter::kIsIterationInvariantRate, benchmark::Counter::kIs1000);
  state.counters["tokens"] = static_cast<double>(grid.rows * grid.cols);
}

void BM_Forward(benchmark::State& state) {
  reset_peak_memory();
  c10::InferenceMode inference;
  MoGe2Model model(moge2_config(kBackbones[state.range(0)]));
  model->eval();
  const AutocastScope autocast(precision_of(state, 2), c10::DeviceType::CPU);
  const at::Tensor image = test_image();
  model->forward(image, state.range(1));  // warm-up
  const double cpu_start = process_cpu_seconds();
  for (auto _ : state) benchmark::DoNotOptimize(model->forward(image, state.range(1)));
  state.counters["cpu_s"] =
      benchmark::Counter(process_cpu_seconds() - cpu_start, benchmark::Counter::kAvgIterations);
  state.counters["peak_MB"] = peak_memory_mb();
}

void variants(benchmark::internal::Benchmark* bench) {
  bench->ArgNames({"vit", "tokens", "bf16"})
      ->Unit(benchmark::kMillisecond)
      ->UseRealTime()
      ->Iterations(1);
  for (int64_t vit = 0; vit < 3; ++vit)
    for (int64_t tokens : {1200, 2400})
      for (int64_t bf16 : {0, 1}) bench->Args({vit, tokens, bf16});
}

BENCHMARK(BM_Gemm)
    ->ArgName("bf16")
    ->Arg(0)
    ->Arg(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->Iterations(5);
BENCHMARK(BM_VitBlocks)->Apply(variants);
BENCHMARK(BM_Forward)->Apply(variants);

}  // namespace

int main(int argc, char** argv) {
  omnipoint::io::keep_freed_memory_in_heap();  // as `omnipoint forward` does
  at::set_num_threads(2);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
