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

// Runs `omnipoint ARGS`, its stdout and stderr captured through files in `scratch`.
inline CliRun run_omnipoint(const std::string& args, const std::filesystem::path& scratch) {
  std::filesystem::create_directories(scratch);
  const std::filesystem::path out = scratch / "stdout", err = scratch / "stderr";
  const std::string command =
      std::string(OMNIPOINT_CLI) + " " + args + " >" + out.string() + " 2>" + err.string();
  const int status = std::system(command.c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, slurp(out), slurp(err)};
}

}  // namespace omnipoint::test
