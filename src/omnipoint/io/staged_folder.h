#pragma once
// A folder that appears complete or not at all: it is written into a hidden staging sibling,
// `.NAME.partial-XXXXXX` beside the destination NAME, and renamed over the destination when
// complete (predict's outputs, training checkpoints, synth's samples).
//
// The owner holds an exclusive flock on the open staging folder for as long as it lives; the
// kernel drops the lock when the process ends, however it ends (SIGKILL included). So a staging
// folder whose lock can be taken is stale — left by a process that died — and creating a staged
// folder first removes the stale ones beside it: a rerun cleans up after a killed run, and never
// touches the folder another live process is writing.
#include <filesystem>
#include <string>

namespace omnipoint::io {

class StagedFolder {
 public:
  // Creates the staging folder beside `destination` (and the parent folders), locked; first
  // removes the stale staging folders in that parent. std::runtime_error naming the destination
  // when it cannot.
  explicit StagedFolder(const std::filesystem::path& destination);
  // Removes the staging folder unless it was committed.
  ~StagedFolder();
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;

  // Where to write the folder's files.
  const std::filesystem::path& path() const { return path_; }
  const std::filesystem::path& destination() const { return destination_; }

  // Renames the staging folder to the destination, replacing what was there (an older folder
  // of that name); the lock is released. std::runtime_error naming the destination when the
  // rename fails (the staging folder is then removed).
  void commit();
  // Removes the staging folder and releases the lock (the destructor does this too).
  void abort();

 private:
  std::filesystem::path destination_;
  std::filesystem::path path_;
  int lock_fd_ = -1;  // the open staging folder, flock'ed; -1 once committed or aborted
};

// The naming rule: whether `path`'s last component is a staging folder's name
// (`.NAME.partial-XXXXXX`). Whatever lists folders of samples or predictions skips these.
bool is_staging_folder(const std::filesystem::path& path);

// Removes the staging folders in `parent` that no live process holds (StagedFolder does this on
// creation). Returns how many it removed.
int remove_stale_staging_folders(const std::filesystem::path& parent);

}  // namespace omnipoint::io
