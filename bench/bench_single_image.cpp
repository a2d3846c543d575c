// Where the time of a single-image process goes: loading the checkpoint, the first forward pass
// (which pays the one-time set-up: weight casts, kernel set-up) and a warm forward pass (the
// network's own time), all in one process on every core, as `omnipoint forward` runs them.
// bench/single_image_latency.sh runs it beside the tool. Results: docs/PERFORMANCE.md.
//
//   bench_single_image MODEL INPUT.npy fp32|bf16 [WARM_RUNS]
// prints one line: load_ms first_ms warm_ms (the median of WARM_RUNS, default 3) peak_MB read_ms,
// where read_ms is the part of loading that reads the file (io::read_weights, timed afterwards
// on its own); the rest of load_ms builds the network and loads the weights into it.
#include <ATen/ATen.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "omnipoint/infer/infer.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/process_memory.h"
#include "omnipoint/io/torch_checkpoint.h"
#include "omnipoint/model/precision.h"

namespace {

using Clock = std::chrono::steady_clock;

double ms_since(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

double peak_memory_mb() {
  std::ifstream status("/proc/self/status");
  for (std::string line; std::getline(status, line);)
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;  // kB
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  omnipoint::io::keep_freed_memory_in_heap();  // as the tool does
  if (argc < 4) {
    std::fprintf(stderr, "usage: bench_single_image MODEL INPUT.npy fp32|bf16 [WARM_RUNS]\n");
    return 2;
  }
  const std::string model = argv[1], input = argv[2];
  const omnipoint::model::Precision precision = omnipoint::model::parse_precision(argv[3]);
  const int warm_runs = argc > 4 ? std::max(1, std::stoi(argv[4])) : 3;
  const at::Tensor image = omnipoint::io::read_npy(input).to(at::kFloat);

  auto start = Clock::now();
  const omnipoint::infer::Network network = omnipoint::infer::load_network(model);
  const double load_ms = ms_since(start);
  start = Clock::now();
  omnipoint::infer::forward(network, image, 0, precision);
  const double first_ms = ms_since(start);
  std::vector<double> warm;
  for (int i = 0; i < warm_runs; ++i) {
    start = Clock::now();
    omnipoint::infer::forward(network, image, 0, precision);
    warm.push_back(ms_since(start));
  }
  std::sort(warm.begin(), warm.end());
  const double peak_mb = peak_memory_mb();
  start = Clock::now();
  omnipoint::io::read_weights(model);
  const double read_ms = ms_since(start);
  std::printf("%.0f %.0f %.0f %.0f %.0f\n", load_ms, first_ms, warm[warm.size() / 2], peak_mb,
              read_ms);
  return 0;
}
