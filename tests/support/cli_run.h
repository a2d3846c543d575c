#pragma once
// Running the built `omnipoint` binary (the OMNIPOINT_CLI macro) from end-to-end tests.
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <string>

#include "support/scratch_dir.h"

namespace omnipoint::test {

struct CliRun {
  int status;  // the exit code, -1 if the process did not exit normally
  std::string out, err;
};

// Runs a shell command, its stdout and stderr captured through files in `scratch`.
inline CliRun run_command(const std::string& command, const std::filesystem::path& scratch) {
  std::filesystem::create_directories(scratch);
  const std::filesystem::path out = scratch / "stdout", err = scratch / "stderr";
  const std::string redirected = command + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(redirected.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

// Runs `omnipoint ARGS` (run_command).
inline CliRun run_omnipoint(const std::string& args, const std::filesystem::path& scratch) {
  return run_command(std::string(OMNIPOINT_CLI) + " " + args, scratch);
}

}  // namespace omnipoint::test
