#include "omnipoint/util/threads.h"

#include <dlfcn.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <mutex>
#include <thread>

namespace omnipoint::util {
namespace {

std::once_flag default_threads_once;
std::atomic<bool> threads_chosen{false};

void set_pools(int threads) {
  at::set_num_threads(threads);
  // LibTorch links libopenblas itself (not the program), so the symbol is found in the
  // process rather than linked; LibTorch never sets OpenBLAS's count.
  using SetThreads = void (*)(int);
  if (void* symbol = dlsym(RTLD_DEFAULT, "openblas_set_num_threads"))
    reinterpret_cast<SetThreads>(symbol)(threads);
}

}  // namespace

int thread_count(int requested, unsigned hardware) {
  if (requested > 0) return requested;
  return static_cast<int>(std::max(1u, hardware));
}

void set_threads(int requested) {
  threads_chosen = true;
  set_pools(thread_count(requested, std::thread::hardware_concurrency()));
}

void use_default_threads() {
  std::call_once(default_threads_once, [] {
    // A count the program set through LibTorch itself, or OMP_NUM_THREADS, is its choice.
    if (threads_chosen || std::getenv("OMP_NUM_THREADS") != nullptr ||
        at::get_num_threads() != at::intraop_default_num_threads())
      return;
    set_pools(thread_count(0, std::thread::hardware_concurrency()));
  });
}

}  // namespace omnipoint::util
