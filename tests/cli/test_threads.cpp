// The tool's threads (cli/threads.h): its passive OpenMP workers, and `--threads` refusing what
// is not a positive count with one line (the count rule and the pools: tests/util).
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <string>

#include "cli/threads.h"
#include "support/cli_run.h"

namespace omnipoint::cli {
namespace {

// libgomp's own report of what it read: the tool runs passive OpenMP workers (a spin count of
// 0) unless the caller chose a policy, and without starting itself a second time (libgomp
// reports once per start of the program).
TEST(ThreadCount, TheToolRunsPassiveOpenMpWorkers) {
  const auto scratch = test::fresh_process_dir("omnipoint_threads_policy");
  const auto libgomp_report = [&](const std::string& environment) {
    const std::string err = (scratch / "stderr").string();
    const std::string command = "env -u OMP_WAIT_POLICY " + environment +
                                " OMP_DISPLAY_ENV=verbose " + OMNIPOINT_CLI + " --version 2>" + err;
    EXPECT_EQ(std::system(command.c_str()), 0) << command;
    return test::slurp(err);
  };
  const auto count = [](const std::string& text, const std::string& what) {
    size_t found = 0;
    for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1))
      ++found;
    return found;
  };
  const std::string by_default = libgomp_report("");
  EXPECT_NE(by_default.find("GOMP_SPINCOUNT = '0'"), std::string::npos) << by_default;
  EXPECT_EQ(count(by_default, "OPENMP DISPLAY ENVIRONMENT BEGIN"), 1u) << by_default;
  EXPECT_EQ(libgomp_report("OMP_WAIT_POLICY=active").find("GOMP_SPINCOUNT = '0'"),
            std::string::npos);
}

TEST(ThreadsOption, NotAPositiveCountIsOneErrorLine) {
  const auto scratch = test::fresh_process_dir("omnipoint_threads_option");
  for (const std::string arguments :
       {"forward --model m.safetensors --input i.npy --out o --threads 0",
        "predict image.png --threads -2", "eval --baseline oracle --data d --out o --threads two",
        "synth --camera \"PINHOLE 8 8 8 8 4 4\" --out o --threads 1.5"}) {
    const test::CliRun run = test::run_omnipoint(arguments, scratch);
    EXPECT_NE(run.status, 0) << arguments;
    EXPECT_EQ(std::count(run.err.begin(), run.err.end(), '\n'), 1) << arguments << ": " << run.err;
    EXPECT_EQ(run.err.rfind("omnipoint: error: ", 0), 0u) << arguments << ": " << run.err;
    EXPECT_NE(run.err.find("--threads"), std::string::npos) << arguments << ": " << run.err;
  }
}

}  // namespace
}  // namespace omnipoint::cli
