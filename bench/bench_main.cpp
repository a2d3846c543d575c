// The main of every Google Benchmark program here: the process runs with the heap settings of
// `omnipoint` itself, so a benchmark times what the tool does.
#include <benchmark/benchmark.h>

#include "omnipoint/io/process_memory.h"

int main(int argc, char** argv) {
  omnipoint::io::keep_freed_memory_in_heap();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
