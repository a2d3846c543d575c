#include "cli/threads.h"

#include <unistd.h>
#include <CLI/CLI.hpp>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "omnipoint/util/threads.h"

namespace {

// LibTorch's OpenMP workers busy-wait after each parallel region unless told otherwise; where
// the cores are taken (a shared machine, the ranks of --nproc) that spinning costs more than
// the second thread gains: a ViT-S predict on two threads took 1.9x as long spinning as
// waiting passively, under load (docs/PERFORMANCE.md). libgomp reads OMP_WAIT_POLICY once, in
// its initialiser, before main and before any code of this program can set it. So this program
// answers libgomp's question itself: its getenv (below) takes the place of the C library's for
// every library of the process, and says "passive" for an OMP_WAIT_POLICY the environment does
// not hold (a policy the user set is kept). Where libgomp did not ask through getenv (another
// OpenMP runtime), use_threads falls back to restarting the program with the variable set.
constexpr char kWaitPolicy[] = "OMP_WAIT_POLICY";
constexpr char kPassive[] = "passive";

// Set when getenv handed out the default policy: libgomp has its answer.
std::atomic<bool> default_policy_supplied{false};

// The environment's own value of `name`, the C library's lookup (runs before any initialiser
// of this program: it reads only `environ`).
char* environment_value(const char* name) {
  const size_t length = std::strlen(name);
  for (char** entry = environ; entry != nullptr && *entry != nullptr; ++entry) {
    if (std::strncmp(*entry, name, length) == 0 && (*entry)[length] == '=')
      return *entry + length + 1;
  }
  return nullptr;
}

void restart_with_passive_openmp() {
  std::ifstream file("/proc/self/cmdline", std::ios::binary);
  std::vector<std::string> arguments;
  for (std::string argument; std::getline(file, argument, '\0');) arguments.push_back(argument);
  if (arguments.empty()) return;
  std::vector<char*> argv;
  argv.reserve(arguments.size() + 1);
  for (std::string& argument : arguments) argv.push_back(argument.data());
  argv.push_back(nullptr);
  setenv(kWaitPolicy, kPassive, /*overwrite=*/1);
  execv("/proc/self/exe", argv.data());
}

}  // namespace

// See the top: the process's getenv, the C library's answer but for an unset OMP_WAIT_POLICY.
extern "C" char* getenv(const char* name) {
  char* value = environment_value(name);
  if (value == nullptr && std::strcmp(name, kWaitPolicy) == 0) {
    default_policy_supplied = true;
    return const_cast<char*>(kPassive);
  }
  return value;
}

namespace omnipoint::cli {

void use_threads(int requested) {
  const int threads = util::thread_count(requested, std::thread::hardware_concurrency());
  const bool policy_known = default_policy_supplied || environment_value(kWaitPolicy) != nullptr;
  if (threads > 1 && !policy_known) restart_with_passive_openmp();
  util::set_threads(threads);
}

CLI::Option* add_threads_option(CLI::App* command, int* threads) {
  return command
      ->add_option("--threads", *threads,
                   "Threads to compute on (LibTorch and OpenBLAS; default: every core)")
      ->check(CLI::PositiveNumber);
}

}  // namespace omnipoint::cli
