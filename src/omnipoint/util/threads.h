#pragma once
// The threads the library computes on, set in one place: LibTorch's intra-op pool (the OpenMP
// threads of at::parallel_for and of LibTorch's own operators) and OpenBLAS's pool get the
// same count, so neither runs on fewer cores than asked nor keeps idle workers beyond them.
//
// The default is every core (std::thread::hardware_concurrency). LibTorch's own default is the
// machine's physical cores, which is one on a two-vCPU machine: a program that linked the
// library and set nothing ran every parallel loop on one thread (P2A 1 MP -> 2048x1024: 284 ms
// against 172 ms). So the library's entry points (building a network, each of its parallel
// loops) call use_default_threads(), and a program gets every core without asking. A program
// chooses with set_threads(); a count it gave at::set_num_threads (other than LibTorch's
// default) and OMP_NUM_THREADS in the environment are its choice too, and left alone.
#include <ATen/Parallel.h>

#include <cstdint>

namespace omnipoint::util {

// `requested` when > 0, else `hardware` (the machine's logical cores), at least 1 (0 is what
// std::thread::hardware_concurrency says when it cannot tell).
int thread_count(int requested, unsigned hardware);

// Sets both pools to thread_count(requested, std::thread::hardware_concurrency()) (0: every
// core), on the calling thread and for threads that start computing after it. OpenBLAS is
// looked up at run time: a LibTorch built on another BLAS (MKL) has none, and MKL follows
// at::set_num_threads itself. From then on use_default_threads() changes nothing.
void set_threads(int requested);

// Every core, once per process, unless the program chose (above). Cheap after the first call.
void use_default_threads();

// at::parallel_for on the library's thread count (use_default_threads first). A template in
// the caller's translation unit, as at::parallel_for is: it runs in parallel only where that
// unit is built with OpenMP (CMakeLists.txt).
template <class Function>
void parallel_for(int64_t begin, int64_t end, int64_t grain_size, const Function& function) {
  use_default_threads();
  at::parallel_for(begin, end, grain_size, function);
}

}  // namespace omnipoint::util
