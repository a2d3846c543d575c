// The library's thread pools (util/threads.h): the count rule, both pools set alike, and every
// core by default in a program that sets nothing (each such test in a fresh process: the
// default is taken once per process).
#include <ATen/Parallel.h>
#include <dlfcn.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <thread>

#include "omnipoint/util/threads.h"

namespace omnipoint::util {
namespace {

int cores() {
  return static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
}

// OpenBLAS's own count, where this LibTorch has OpenBLAS (-1 otherwise).
int openblas_threads() {
  using GetThreads = int (*)();
  void* symbol = dlsym(RTLD_DEFAULT, "openblas_get_num_threads");
  return symbol != nullptr ? reinterpret_cast<GetThreads>(symbol)() : -1;
}

TEST(ThreadCount, DefaultIsEveryCoreAndAGivenCountWins) {
  EXPECT_EQ(thread_count(0, 8), 8);
  EXPECT_EQ(thread_count(0, 2), 2);
  EXPECT_EQ(thread_count(3, 8), 3);
  EXPECT_EQ(thread_count(16, 2), 16);  // more than the cores, when asked for
  EXPECT_EQ(thread_count(0, 0), 1);    // the machine cannot tell
}

TEST(ThreadCount, SetThreadsSetsLibTorchAndOpenBlasAlike) {
  for (const int requested : {1, 0, 3}) {
    set_threads(requested);
    const int expected = requested > 0 ? requested : cores();
    EXPECT_EQ(at::get_num_threads(), expected) << requested;
    if (openblas_threads() != -1) {
      EXPECT_EQ(openblas_threads(), expected) << requested;
    }
  }
}

// A fresh process of this test program (gtest's threadsafe death-test style re-runs the
// program for the one test), so that nothing earlier chose a count.
class FreshProcess : public ::testing::Test {
 protected:
  void SetUp() override { GTEST_FLAG_SET(death_test_style, "threadsafe"); }
};

TEST_F(FreshProcess, EveryCoreWithoutAsking) {
  EXPECT_EXIT(
      {
        unsetenv("OMP_NUM_THREADS");
        use_default_threads();
        const bool every_core = at::get_num_threads() == cores() &&
                                (openblas_threads() == -1 || openblas_threads() == cores());
        std::exit(every_core ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST_F(FreshProcess, AChosenCountStays) {
  EXPECT_EXIT(
      {
        unsetenv("OMP_NUM_THREADS");
        set_threads(1);
        use_default_threads();
        std::exit(at::get_num_threads() == 1 ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST_F(FreshProcess, ACountGivenToLibTorchStays) {
  EXPECT_EXIT(
      {
        unsetenv("OMP_NUM_THREADS");
        const int chosen = at::intraop_default_num_threads() + 1;
        at::set_num_threads(chosen);
        use_default_threads();
        std::exit(at::get_num_threads() == chosen ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

TEST_F(FreshProcess, OmpNumThreadsIsTheUsersChoice) {
  EXPECT_EXIT(
      {
        setenv("OMP_NUM_THREADS", "1", 1);
        at::set_num_threads(1);
        use_default_threads();
        std::exit(at::get_num_threads() == 1 ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "");
}

#ifdef OMNIPOINT_TSAN
// The ThreadSanitizer lane sees the threads of a parallel loop: chunks that write one counter
// unguarded are reported, and the report ends the process with TSan's exit code (66), so the
// lane cannot pass by not looking (this file is built with OpenMP in that lane).
TEST_F(FreshProcess, TheThreadSanitizerLaneSeesARaceInAParallelLoop) {
  EXPECT_EXIT(
      {
        set_threads(2);
        int64_t counter = 0;
        parallel_for(0, 2, 1, [&](int64_t begin, int64_t end) {
          for (int64_t i = begin; i < end; ++i) ++counter;
        });
        std::exit(counter == 2 ? 0 : 1);
      },
      ::testing::ExitedWithCode(66), "ThreadSanitizer: data race");
}
#endif

}  // namespace
}  // namespace omnipoint::util
