// Weights loading speed: parsing an in-memory safetensors image and reading a file
// (memory-mapped, page cache warm), float32 as stored and float16 converted to float32.
// The file holds 192 MiB of float32 tensors shaped like four ViT-L blocks (1024 wide).
#include <ATen/ATen.h>
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <optional>
#include <string>

#include "omnipoint/io/safetensors.h"

namespace {

constexpr int64_t kWidth = 1024;
constexpr int kBlocks = 4;  // 4 x (qkv 3C*C + proj C*C + fc1 4C*C + fc2 C*4C) floats = 192 MiB

std::map<std::string, at::Tensor> vit_like_weights() {
  std::map<std::string, at::Tensor> out;
  for (int b = 0; b < kBlocks; ++b) {
    const std::string p = "blocks." + std::to_string(b) + ".";
    out[p + "attn.qkv.weight"] = at::randn({3 * kWidth, kWidth});
    out[p + "attn.proj.weight"] = at::randn({kWidth, kWidth});
    out[p + "mlp.fc1.weight"] = at::randn({4 * kWidth, kWidth});
    out[p + "mlp.fc2.weight"] = at::randn({kWidth, 4 * kWidth});
  }
  return out;
}

int64_t tensor_bytes(const std::map<std::string, at::Tensor>& tensors) {
  int64_t n = 0;
  for (const auto& [name, t] : tensors) n += t.numel() * t.element_size();
  return n;
}

void BM_ParseSafetensors(benchmark::State& state) {
  const auto tensors = vit_like_weights();
  const std::string bytes = omnipoint::io::encode_safetensors(tensors);
  for (auto _ : state) {
    auto file = omnipoint::io::parse_safetensors(bytes.data(), bytes.size(), "bench");
    benchmark::DoNotOptimize(file);
  }
  state.SetBytesProcessed(state.iterations() * tensor_bytes(tensors));
}

void read_file(benchmark::State& state, std::optional<at::ScalarType> stored) {
  const auto tensors = vit_like_weights();
  const std::string path =
      (std::filesystem::temp_directory_path() / "omnipoint_bench.safetensors").string();
  omnipoint::io::write_safetensors(path, tensors, {}, stored);
  for (auto _ : state) {
    auto file = omnipoint::io::read_safetensors(path, at::kFloat);
    benchmark::DoNotOptimize(file);
  }
  state.SetBytesProcessed(state.iterations() * tensor_bytes(tensors));  // float32 bytes delivered
  std::filesystem::remove(path);
}

void BM_ReadSafetensorsF32(benchmark::State& state) {
  read_file(state, at::kFloat);
}
void BM_ReadSafetensorsF16ToF32(benchmark::State& state) {
  read_file(state, at::kHalf);
}

void BM_EncodeSafetensors(benchmark::State& state) {
  const auto tensors = vit_like_weights();
  for (auto _ : state) benchmark::DoNotOptimize(omnipoint::io::encode_safetensors(tensors));
  state.SetBytesProcessed(state.iterations() * tensor_bytes(tensors));
}

}  // namespace

BENCHMARK(BM_ParseSafetensors)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ReadSafetensorsF32)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_ReadSafetensorsF16ToF32)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK(BM_EncodeSafetensors)->Unit(benchmark::kMillisecond)->UseRealTime();
