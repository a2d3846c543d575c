#include "cli/threads.h"

#include <unistd.h>
#include <CLI/CLI.hpp>

#include <cstdlib>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "omnipoint/util/threads.h"

namespace omnipoint::cli {
namespace {

// LibTorch's OpenMP workers busy-wait after each parallel region unless told otherwise; where
// the cores are taken (a shared machine, the ranks of --nproc) that spinning costs more than
// the second thread gains: a ViT-S predict on two threads took 1.9x as long spinning as
// waiting passively, under load (docs/PERFORMANCE.md). libgomp reads OMP_WAIT_POLICY once, as
// it loads, before main: without it this program sets it and starts itself again (a policy the
// user set is kept; when the restart fails, the run carries on as it is).
void restart_with_passive_openmp() {
  std::ifstream file("/proc/self/cmdline", std::ios::binary);
  std::vector<std::string> arguments;
  for (std::string argument; std::getline(file, argument, '\0');) arguments.push_back(argument);
  if (arguments.empty()) return;
  std::vector<char*> argv;
  argv.reserve(arguments.size() + 1);
  for (std::string& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  setenv("OMP_WAIT_POLICY", "passive", /*overwrite=*/1);
  execv("/proc/self/exe", argv.data());
}

}  // namespace

void use_threads(int requested) {
  const int threads = util::thread_count(requested, std::thread::hardware_concurrency());
  if (threads > 1 && std::getenv("OMP_WAIT_POLICY") == nullptr) restart_with_passive_openmp();
  util::set_threads(threads);
}

CLI::Option* add_threads_option(CLI::App* command, int* threads) {
  return command
      ->add_option("--threads", *threads,
                   "Threads to compute on (LibTorch and OpenBLAS; default: every core)")
      ->check(CLI::PositiveNumber);
}

}  // namespace omnipoint::cli
