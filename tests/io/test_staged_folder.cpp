// io::StagedFolder: a folder appears complete or not at all, and a staging folder left by a
// killed process is removed by the next one, never one that a live process is writing.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/staged_folder.h"
#include "support/scratch_dir.h"

namespace omnipoint::io {
namespace {

namespace fs = std::filesystem;

int staging_folders_in(const fs::path& parent) {
  int count = 0;
  for (const fs::directory_entry& entry : fs::directory_iterator(parent))
    count += is_staging_folder(entry.path()) ? 1 : 0;
  return count;
}

TEST(StagedFolder, NamingRule) {
  EXPECT_TRUE(is_staging_folder(".photo.partial-Ab12Z9"));
  EXPECT_TRUE(is_staging_folder("out/a/.step_00000100.partial-xxxxxx"));
  EXPECT_TRUE(is_staging_folder(".a.b.partial-000000"));
  EXPECT_FALSE(is_staging_folder("photo"));
  EXPECT_FALSE(is_staging_folder("photo.partial"));            // the name of older versions
  EXPECT_FALSE(is_staging_folder("photo.partial-Ab12Z9"));     // not hidden
  EXPECT_FALSE(is_staging_folder(".partial-Ab12Z9"));          // no name
  EXPECT_FALSE(is_staging_folder(".photo.partial-Ab12Z"));     // suffix too short
  EXPECT_FALSE(is_staging_folder(".photo.partial-Ab12Z9x"));   // too long
  EXPECT_FALSE(is_staging_folder(".photo.partial-Ab1.Z9"));    // not mkdtemp's letters
  EXPECT_FALSE(is_staging_folder(".photo.partial-Ab12Z9/x"));  // a file inside one
}

TEST(StagedFolder, CommitRenamesIntoPlaceReplacingAnOlderFolder) {
  const fs::path dir = test::fresh_process_dir("omnipoint_staged_commit");
  const fs::path destination = dir / "deep" / "sample";
  {
    StagedFolder staged(destination);
    EXPECT_EQ(staged.destination(), destination);
    EXPECT_EQ(staged.path().parent_path(), dir / "deep");
    EXPECT_TRUE(is_staging_folder(staged.path()));
    EXPECT_EQ(staged.path().filename().string().rfind(".sample.partial-", 0), 0u);
    std::ofstream(staged.path() / "a.txt") << "first";
    EXPECT_FALSE(fs::exists(destination));  // nothing shows before the commit
    staged.commit();
    EXPECT_FALSE(fs::exists(staged.path()));
    EXPECT_THROW(staged.commit(), std::logic_error);
  }
  EXPECT_EQ(read_file((destination / "a.txt").string()), "first");
  {
    StagedFolder staged(destination);
    std::ofstream(staged.path() / "b.txt") << "second";
    EXPECT_TRUE(fs::exists(destination / "a.txt"));  // the older folder stays until the commit
    staged.commit();
  }
  EXPECT_FALSE(fs::exists(destination / "a.txt"));
  EXPECT_EQ(read_file((destination / "b.txt").string()), "second");
  EXPECT_EQ(staging_folders_in(dir / "deep"), 0);
  // A trailing separator names the same folder.
  StagedFolder slash(dir / "deep" / "other" / "");
  EXPECT_EQ(slash.destination(), dir / "deep" / "other");
  EXPECT_THROW(StagedFolder(dir / "."), std::runtime_error);
  fs::remove_all(dir);
}

TEST(StagedFolder, AbortAndTheDestructorRemoveItAndKeepTheDestination) {
  const fs::path dir = test::fresh_process_dir("omnipoint_staged_abort");
  fs::create_directories(dir / "kept");
  std::ofstream(dir / "kept" / "old.txt") << "old";
  fs::path staging;
  {
    StagedFolder staged(dir / "kept");
    staging = staged.path();
    std::ofstream(staged.path() / "new.txt") << "new";
  }  // an exception on the way out, say
  EXPECT_FALSE(fs::exists(staging));
  StagedFolder aborted(dir / "kept");
  aborted.abort();
  EXPECT_FALSE(fs::exists(aborted.path()));
  aborted.abort();  // twice is harmless
  EXPECT_THROW(aborted.commit(), std::logic_error);
  EXPECT_EQ(read_file((dir / "kept" / "old.txt").string()), "old");
  EXPECT_EQ(staging_folders_in(dir), 0);
  fs::remove_all(dir);
}

// A child process stages a folder, reports its path and waits; the parent reads the path.
struct StagingChild {
  pid_t pid = -1;
  int hold_fd = -1;  // the child waits until this closes (or it is killed)
  fs::path staging;

  explicit StagingChild(const fs::path& destination) {
    int report[2], hold[2];
    if (::pipe(report) != 0 || ::pipe(hold) != 0) throw std::runtime_error("pipe");
    pid = ::fork();
    if (pid < 0) throw std::runtime_error("fork");
    if (pid == 0) {
      ::close(report[0]);
      ::close(hold[1]);
      StagedFolder staged(destination);
      std::ofstream(staged.path() / "half.txt") << "half";
      const std::string path = staged.path().string() + "\n";
      if (::write(report[1], path.data(), path.size()) != static_cast<ssize_t>(path.size()))
        ::_exit(2);
      char byte = 0;
      while (::read(hold[0], &byte, 1) > 0) {
      }
      ::_exit(0);  // as if killed: no destructor runs
    }
    ::close(report[1]);
    ::close(hold[0]);
    hold_fd = hold[1];
    std::string path;
    char c = 0;
    while (::read(report[0], &c, 1) == 1 && c != '\n') path += c;
    ::close(report[0]);
    staging = path;
  }
  void kill() {
    ::kill(pid, SIGKILL);
    int status = 0;
    ::waitpid(pid, &status, 0);
    ::close(hold_fd);
    pid = -1;
  }
  ~StagingChild() {
    if (pid > 0) kill();
  }
};

TEST(StagedFolder, AKilledProcessLeavesItsStagingFolderAndTheNextOneRemovesIt) {
  const fs::path dir = test::fresh_process_dir("omnipoint_staged_killed");
  StagingChild live(dir / "photo");
  ASSERT_TRUE(is_staging_folder(live.staging)) << live.staging;
  ASSERT_TRUE(fs::exists(live.staging / "half.txt"));
  // The child is alive: its folder is not stale, neither for a new staged folder beside it nor
  // for the explicit clean-up.
  StagedFolder mine(dir / "other");
  EXPECT_TRUE(fs::exists(live.staging / "half.txt"));
  EXPECT_EQ(remove_stale_staging_folders(dir), 0);
  EXPECT_TRUE(fs::exists(live.staging));
  EXPECT_TRUE(fs::exists(mine.path()));  // nor is this process's own

  live.kill();  // SIGKILL: nothing of the child's clean-up runs
  EXPECT_TRUE(fs::exists(live.staging / "half.txt"));
  {
    StagedFolder next(dir / "photo");  // the rerun
    EXPECT_FALSE(fs::exists(live.staging));
    EXPECT_TRUE(fs::exists(mine.path()));
    next.commit();
  }
  EXPECT_EQ(staging_folders_in(dir), 1);  // `mine`, still being written

  StagingChild killed(dir / "photo");
  killed.kill();
  EXPECT_EQ(remove_stale_staging_folders(dir), 1);
  EXPECT_FALSE(fs::exists(killed.staging));
  EXPECT_TRUE(fs::exists(dir / "photo"));
  mine.commit();
  EXPECT_EQ(staging_folders_in(dir), 0);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace omnipoint::io
