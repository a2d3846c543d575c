// Training batches on one thread against THREADS threads, interleaved step by step in one run
// (the same batches: BatchSource's items do not depend on the thread count). Prints the mean
// wall milliseconds per batch of each and their ratio; docs/PERFORMANCE.md has the results.
//   bench_batch_source CONFIG [STEPS=6] [THREADS=2]
// The batches are stage-2 ones (conditions and augmentations on), from step 0 on.
#include <ATen/Parallel.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>

#include "omnipoint/train/batch_source.h"

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::fprintf(stderr, "usage: %s CONFIG [STEPS] [THREADS]\n", argv[0]);
    return 2;
  }
  try {
    using namespace omnipoint::train;
    const TrainConfig config = TrainConfig::load(argv[1]);
    const int steps = argc > 2 ? std::atoi(argv[2]) : 6;
    const int threads = argc > 3 ? std::atoi(argv[3]) : 2;
    if (steps < 1 || threads < 1) {
      std::fprintf(stderr, "bench_batch_source: STEPS and THREADS must be positive\n");
      return 2;
    }
    const BatchSource source(config);
    const auto milliseconds = [&](int thread_count, int64_t step) {
      at::set_num_threads(thread_count);
      const auto start = std::chrono::steady_clock::now();
      const TrainingBatch batch = source.batch(step, true);
      return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
          .count();
    };
    milliseconds(threads, steps);  // warm-up: thread pool, first allocations
    double one = 0, many = 0;
    for (int step = 0; step < steps; ++step) {
      one += milliseconds(1, step);
      many += milliseconds(threads, step);
    }
    std::printf("%s: %d batches of %lld items\n", argv[1], steps,
                static_cast<long long>(config.batch_size));
    std::printf("1 thread   %9.1f ms/batch\n%d threads %9.1f ms/batch\nratio      %9.2f\n",
                one / steps, threads, many / steps, one / many);
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bench_batch_source: %s\n", error.what());
    return 1;
  }
}
