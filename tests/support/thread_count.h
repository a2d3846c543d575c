#pragma once
// LibTorch's intra-op thread count for a scope: tests that run the same work on one thread and
// on two compare the results (the parallel loops of this library must not change them).
#include <ATen/Parallel.h>

namespace omnipoint::test {

class ThreadCount {
 public:
  explicit ThreadCount(int threads) : before_(at::get_num_threads()) {
    at::set_num_threads(threads);
  }
  ~ThreadCount() { at::set_num_threads(before_); }
  ThreadCount(const ThreadCount&) = delete;
  ThreadCount& operator=(const ThreadCount&) = delete;

 private:
  int before_;
};

}  // namespace omnipoint::test
