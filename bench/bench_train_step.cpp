// Where the time of a training step goes: runs a training config's first steps in this process
// (one rank) and prints the mean wall seconds per phase (data, forward, each loss term,
// backward, optimizer) over the measured steps, and images/s. docs/PERFORMANCE.md has the
// results; `omnipoint train` logs the same phases per step ("seconds" in log.jsonl).
//   bench_train_step CONFIG [MEASURED_STEPS=20] [WARMUP_STEPS=3] [START_STEP=0]
// START_STEP > 0 starts in the middle of the schedule (e.g. stage 2, with its conditions and
// augmentations) by setting the step counter; the weights are the config's initial ones.
#include <ATen/Parallel.h>

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <map>
#include <string>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/process_memory.h"
#include "omnipoint/train/trainer.h"

int main(int argc, char** argv) {
  if (argc < 2 || argc > 5) {
    std::fprintf(stderr, "usage: %s CONFIG [MEASURED_STEPS] [WARMUP_STEPS] [START_STEP]\n",
                 argv[0]);
    return 2;
  }
  omnipoint::io::keep_freed_memory_in_heap();  // as `omnipoint` does
  try {
    using namespace omnipoint::train;
    const TrainConfig config = TrainConfig::load(argv[1]);
    const int measured = argc > 2 ? std::atoi(argv[2]) : 20;
    const int warmup = argc > 3 ? std::atoi(argv[3]) : 3;
    const int64_t start = argc > 4 ? std::atoll(argv[4]) : 0;
    if (measured < 1 || warmup < 0 || start < 0 ||
        start + warmup + measured > config.total_steps()) {
      std::fprintf(stderr, "bench_train_step: the steps do not fit the config's %lld\n",
                   static_cast<long long>(config.total_steps()));
      return 2;
    }
    Trainer trainer(config, build_model(config));
    if (start > 0) {
      TrainState state = trainer.state();
      state.progress["step"] = start;
      state.progress["optimizer_stage"] = -1;
      trainer.restore(state);
    }
    for (int i = 0; i < warmup; ++i) trainer.train_step();
    std::map<std::string, double> sums;
    double total = 0;
    int64_t images = 0;
    for (int i = 0; i < measured; ++i) {
      const StepRecord record = trainer.train_step();
      for (const auto& [phase, seconds] : record.seconds) sums[phase] += seconds;
      for (const char* phase : {"data", "forward", "loss", "backward", "optimizer"})
        total += record.seconds.at(phase);
      images += record.images;
    }
    std::printf("%s: %d steps of %lld images, %d intra-op thread(s)\n", argv[1], measured,
                static_cast<long long>(config.batch_size), at::get_num_threads());
    std::printf("%-16s %10s %7s\n", "phase", "ms/step", "share");
    for (const auto& [phase, sum] : sums)
      std::printf("%-16s %10.2f %6.1f%%\n", phase.c_str(), 1e3 * sum / measured,
                  100.0 * sum / total);
    std::printf("%-16s %10.2f\nimages/s %.2f\n", "step", 1e3 * total / measured,
                static_cast<double>(images) / total);
    return 0;
  } catch (const std::exception& error) {
    std::fprintf(stderr, "bench_train_step: %s\n", error.what());
    return 1;
  }
}
