#pragma once
// How many threads a command computes on. main() gives every command the machine's cores;
// `--threads N` (predict, forward, eval, synth) overrides; `train` uses its config's "threads"
// per rank (default 1: each rank of `--nproc 2` gets one). The pools themselves are set in
// the library's one place (omnipoint/util/threads.h); what the tool adds is the OpenMP wait
// policy of its own process (threads.cpp: why).
namespace CLI {
class App;
class Option;
}  // namespace CLI

namespace omnipoint::cli {

// util::set_threads(requested). The tool's OpenMP workers wait passively unless
// OMP_WAIT_POLICY says otherwise (threads.cpp: why and how); where the OpenMP runtime did not
// take that default as it loaded, with more than one thread, first restarts this program with
// OMP_WAIT_POLICY=passive.
void use_threads(int requested);

// `--threads N` (N >= 1) on `command`, stored in *threads; the command's callback then calls
// use_threads(*threads).
CLI::Option* add_threads_option(CLI::App* command, int* threads);

}  // namespace omnipoint::cli
