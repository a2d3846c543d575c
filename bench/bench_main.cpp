// The main of every Google Benchmark program here: the process runs with the heap settings of
// `omnipoint` itself and on the library's default threads (every core, util/threads.h), and
// the report's context names the thread count, so a benchmark times what the tool does.
#include <ATen/Parallel.h>
#include <benchmark/benchmark.h>

#include <string>

#include "omnipoint/io/process_memory.h"
#include "omnipoint/util/threads.h"

int main(int argc, char** argv) {
  omnipoint::io::keep_freed_memory_in_heap();
  omnipoint::util::use_default_threads();
  benchmark::AddCustomContext("threads", std::to_string(at::get_num_threads()));
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
