// Gradient all-reduce over c10d Gloo between 2 ranks on localhost (one thread each, as in
// the tests): a ViT-S-sized gradient set (12 blocks, 22.0 M float32 values, 88 MB, in 148 tensors)
// averaged with buckets of the given size; 1 byte = one all-reduce per tensor.
#include <benchmark/benchmark.h>

#include <ATen/ATen.h>

#include <thread>

#include "omnipoint/train/distributed.h"
#include "omnipoint/train/launcher.h"

namespace {

using omnipoint::train::DistributedContext;
using omnipoint::train::DistributedEnv;
using omnipoint::train::DistributedOptions;

std::vector<at::Tensor> vit_small_gradients() {
  const int64_t d = 384;
  std::vector<at::Tensor> tensors;
  for (int block = 0; block < 12; ++block) {
    for (const auto& shape : std::vector<std::vector<int64_t>>{{d},
                                                               {d},
                                                               {3 * d, d},
                                                               {3 * d},
                                                               {d, d},
                                                               {d},
                                                               {d},
                                                               {d},
                                                               {4 * d, d},
                                                               {4 * d},
                                                               {d, 4 * d},
                                                               {d}})
      tensors.push_back(at::randn(shape));
  }
  for (const auto& shape : std::vector<std::vector<int64_t>>{{d, 3, 14, 14}, {d}, {1370, d}, {d}})
    tensors.push_back(at::randn(shape));
  return tensors;
}

void BM_AllReduceGradients(benchmark::State& state) {
  DistributedOptions options;
  options.bucket_bytes = state.range(0);
  const int port = omnipoint::train::free_port();
  const int64_t iterations = static_cast<int64_t>(state.max_iterations);
  std::thread peer([&] {
    const DistributedContext context(DistributedEnv{1, 2, 1, "127.0.0.1", port}, options);
    const auto gradients = vit_small_gradients();
    for (int64_t i = 0; i < iterations; ++i) context.all_reduce_mean_(gradients);
  });
  const DistributedContext context(DistributedEnv{0, 2, 0, "127.0.0.1", port}, options);
  const auto gradients = vit_small_gradients();
  int64_t bytes = 0, reduces = 0;
  for (const at::Tensor& g : gradients) bytes += g.numel() * 4;
  for (auto _ : state) reduces = context.all_reduce_mean_(gradients);
  peer.join();
  state.SetBytesProcessed(iterations * bytes);
  state.counters["all_reduces"] = static_cast<double>(reduces);
}
BENCHMARK(BM_AllReduceGradients)
    ->Arg(1)
    ->Arg(1 << 20)
    ->Arg(25 << 20)
    ->Iterations(5)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
