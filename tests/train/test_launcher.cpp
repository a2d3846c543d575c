// launch_local: the torchrun-style environment of each copy, exit codes, and stopping the
// other copies when one fails. The copies are small /bin/sh scripts.
#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include "omnipoint/train/launcher.h"

namespace omnipoint::train {
namespace {

int run_shell(int nproc, const std::string& script, const std::string& argument = "") {
  return launch_local(nproc, {"-c", script, argument}, "/bin/sh");
}

TEST(LauncherTest, EachCopyGetsItsRankAndTheSharedRendezvous) {
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / ("omnipoint_launch_" + std::to_string(free_port()));
  std::filesystem::create_directories(out);
  setenv("RANK", "7", 1);  // a stale value of the parent must not reach the copies
  const int code = run_shell(
      3,
      "test \"$WORLD_SIZE\" = 3 && test \"$MASTER_ADDR\" = 127.0.0.1 && "
      "test \"$LOCAL_RANK\" = \"$RANK\" && echo \"$RANK $MASTER_PORT\" > \"$0/rank$RANK\"",
      out.string());
  unsetenv("RANK");
  ASSERT_EQ(code, 0);
  std::set<std::string> ports;
  for (int rank = 0; rank < 3; ++rank) {
    std::ifstream file(out / ("rank" + std::to_string(rank)));
    int read_rank = -1;
    std::string port;
    ASSERT_TRUE(file >> read_rank >> port) << "rank " << rank << " wrote nothing";
    EXPECT_EQ(read_rank, rank);
    ports.insert(port);
  }
  EXPECT_EQ(ports.size(), 1u);
  EXPECT_GT(std::stoi(*ports.begin()), 0);
  std::filesystem::remove_all(out);
}

TEST(LauncherTest, AFailureStopsTheOthersAndIsForwarded) {
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(run_shell(3, "if [ \"$RANK\" = 1 ]; then exit 3; fi; exec sleep 60"), 3);
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
  EXPECT_EQ(run_shell(2, "if [ \"$RANK\" = 0 ]; then kill -9 $$; fi; exec sleep 60"), 128 + 9);
}

// Whether the process is gone (or only a zombie waiting to be reaped).
bool ended(pid_t pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string pid_field, name, state;
  return !(stat >> pid_field >> name >> state) || state == "Z";
}

// The copies end with the launcher, also when it is killed outright: orphaned ranks would go on
// training beside a resumed run.
TEST(LauncherTest, CopiesEndWhenTheLauncherIsKilled) {
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / ("omnipoint_orphans_" + std::to_string(free_port()));
  std::filesystem::create_directories(out);
  const pid_t launcher = fork();
  if (launcher == 0) {
    launch_local(2,
                 {"-c",
                  "echo $$ > \"$0/rank$RANK.tmp\" && mv \"$0/rank$RANK.tmp\" "
                  "\"$0/rank$RANK\" && exec sleep 60",
                  out.string()},
                 "/bin/sh");
    _exit(0);
  }
  ASSERT_GT(launcher, 0);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!(std::filesystem::exists(out / "rank0") && std::filesystem::exists(out / "rank1")) &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  std::vector<pid_t> ranks;
  for (const char* name : {"rank0", "rank1"}) {
    std::ifstream file(out / name);
    pid_t pid = 0;
    ASSERT_TRUE(file >> pid) << name << " was not written";
    ranks.push_back(pid);
  }
  for (const pid_t pid : ranks) EXPECT_FALSE(ended(pid));
  kill(launcher, SIGKILL);
  int status = 0;
  waitpid(launcher, &status, 0);
  for (const pid_t pid : ranks) {
    while (!ended(pid) && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    EXPECT_TRUE(ended(pid)) << "rank " << pid << " outlived its launcher";
    if (!ended(pid)) kill(pid, SIGKILL);
  }
  std::filesystem::remove_all(out);
}

TEST(LauncherTest, BadInputs) {
  EXPECT_THROW(launch_local(0, {}), std::invalid_argument);
  EXPECT_EQ(launch_local(1, {}, "/nonexistent/omnipoint"), 127);  // exec failed
  EXPECT_FALSE(current_executable().empty());
}

}  // namespace
}  // namespace omnipoint::train
