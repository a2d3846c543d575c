#pragma once
// How many threads a command computes on, and the one place that sets it: LibTorch's intra-op
// pool and OpenBLAS's own pool get the same count, so neither runs on one core (LibTorch's
// default here) nor keeps idle workers beyond it. main() gives every command the machine's
// cores; `--threads N` (predict, forward, eval, synth) overrides; `train` uses its config's
// "threads" per rank (default 1: each rank of `--nproc 2` gets one).
namespace CLI {
class App;
class Option;
}  // namespace CLI

namespace omnipoint::cli {

// `requested` when > 0, else `hardware` (the machine's logical cores), at least 1 (0 is what
// std::thread::hardware_concurrency says when it cannot tell).
int thread_count(int requested, unsigned hardware);

// Sets both pools to thread_count(requested, std::thread::hardware_concurrency()). OpenBLAS is
// looked up at run time: a LibTorch built on another BLAS (MKL) has none, and MKL follows
// at::set_num_threads itself. With more than one thread and no OMP_WAIT_POLICY in the
// environment, first restarts this program with OMP_WAIT_POLICY=passive (threads.cpp: why).
void use_threads(int requested);

// `--threads N` (N >= 1) on `command`, stored in *threads; the command's callback then calls
// use_threads(*threads).
CLI::Option* add_threads_option(CLI::App* command, int* threads);

}  // namespace omnipoint::cli
