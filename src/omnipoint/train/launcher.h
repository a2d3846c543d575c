#pragma once
// `omnipoint train --nproc N`: N copies of a program on this machine, started the way
// torchrun starts them (RANK = LOCAL_RANK = 0..N-1, WORLD_SIZE = N, MASTER_ADDR = 127.0.0.1,
// MASTER_PORT = a free port), for distributed.h to pick up. POSIX only.
#include <string>
#include <vector>

namespace omnipoint::train {

// The path of the running program (/proc/self/exe).
std::string current_executable();

// Runs `executable` with `arguments` (argv[1..]) N times with the variables above added to this
// process's environment, and waits. Returns 0 when every copy exits with 0; otherwise, as soon
// as one copy fails, stops the others (SIGTERM, SIGKILL after a grace period) and returns the
// first failure's exit code (128 + signal number for a signal). std::invalid_argument for
// nproc < 1, std::runtime_error when a copy cannot be started.
int launch_local(int nproc, const std::vector<std::string>& arguments,
                 const std::string& executable = current_executable());

// A TCP port on 127.0.0.1 that was free a moment ago (the kernel's choice for port 0).
int free_port();

}  // namespace omnipoint::train
