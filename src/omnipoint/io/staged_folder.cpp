#include "omnipoint/io/staged_folder.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <system_error>
#include <vector>

namespace omnipoint::io {
namespace {

namespace fs = std::filesystem;

constexpr char kMarker[] = ".partial-";
constexpr size_t kMarkerLength = sizeof(kMarker) - 1;
constexpr size_t kSuffixLength = 6;  // mkdtemp's XXXXXX

std::string system_message(int error) {
  return std::generic_category().message(error);
}

// The folder opened for its lock (not following a symlink); -1 when it is not a folder.
int open_folder(const fs::path& path) {
  return ::open(path.c_str(), O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
}

// On a file system without flock the call fails for the owner and for every cleaner alike, so
// such staging folders are simply never taken for stale.
int lock_folder(int fd, int operation) {
  int result = 0;
  do {
    result = ::flock(fd, operation);
  } while (result != 0 && errno == EINTR);
  return result;
}

// Whether the open folder `fd` is still the one named `path`.
bool still_named(int fd, const fs::path& path) {
  struct stat opened {};
  struct stat named {};
  return ::fstat(fd, &opened) == 0 && ::lstat(path.c_str(), &named) == 0 &&
         opened.st_dev == named.st_dev && opened.st_ino == named.st_ino;
}

}  // namespace

bool is_staging_folder(const fs::path& path) {
  const std::string name = path.filename().string();
  const size_t marker = name.rfind(kMarker);
  // "." + a non-empty NAME + the marker + the suffix.
  if (name.empty() || name.front() != '.' || marker == std::string::npos || marker < 2 ||
      name.size() != marker + kMarkerLength + kSuffixLength)
    return false;
  return std::all_of(name.end() - kSuffixLength, name.end(),
                     [](unsigned char c) { return std::isalnum(c) != 0; });
}

int remove_stale_staging_folders(const fs::path& parent) {
  // Listed first, removed after: a folder is not changed while it is being read.
  std::vector<fs::path> candidates;
  std::error_code error;
  for (fs::directory_iterator entry(parent, error), end; !error && entry != end;
       entry.increment(error))
    if (is_staging_folder(entry->path())) candidates.push_back(entry->path());
  int removed = 0;
  for (const fs::path& candidate : candidates) {
    const int fd = open_folder(candidate);
    if (fd < 0) continue;  // gone meanwhile, or not a folder
    if (lock_folder(fd, LOCK_EX | LOCK_NB) == 0) {
      std::error_code ignored;
      fs::remove_all(candidate, ignored);
      if (!fs::exists(fs::symlink_status(candidate, ignored))) ++removed;
    }
    ::close(fd);
  }
  return removed;
}

StagedFolder::StagedFolder(const fs::path& destination) : destination_(destination) {
  if (!destination_.has_filename()) destination_ = destination_.parent_path();  // "out/"
  const std::string name = destination_.filename().string();
  const auto fail = [&](const std::string& why) {
    throw std::runtime_error("folder " + destination_.string() + ": cannot stage it: " + why);
  };
  if (name.empty() || name == "." || name == "..") fail("not a folder name");
  const fs::path parent = destination_.has_parent_path() ? destination_.parent_path() : ".";
  std::error_code error;
  fs::create_directories(parent, error);
  if (error) fail(error.message());
  remove_stale_staging_folders(parent);
  // A cleaner in another process may take a new folder between its creation and its lock (it
  // looks stale then); the lock waits for that cleaner, and a folder it removed is made again.
  for (int attempt = 0; attempt < 10; ++attempt) {
    std::string pattern = (parent / ("." + name + kMarker + "XXXXXX")).string();
    if (::mkdtemp(pattern.data()) == nullptr) fail(system_message(errno));
    const int fd = open_folder(pattern);
    if (fd < 0) continue;
    lock_folder(fd, LOCK_EX);
    if (still_named(fd, pattern)) {
      path_ = pattern;
      lock_fd_ = fd;
      return;
    }
    ::close(fd);
  }
  fail("its staging folders in " + parent.string() + " keep disappearing");
}

StagedFolder::~StagedFolder() {
  abort();
}

void StagedFolder::commit() {
  if (lock_fd_ < 0)
    throw std::logic_error("staged folder " + destination_.string() +
                           ": committed or aborted already");
  std::error_code error;
  fs::remove_all(destination_, error);
  if (!error) fs::rename(path_, destination_, error);
  if (error) {
    abort();
    throw std::runtime_error("folder " + destination_.string() +
                             ": cannot move it into place: " + error.message());
  }
  ::close(lock_fd_);
  lock_fd_ = -1;
}

void StagedFolder::abort() {
  if (lock_fd_ < 0) return;
  std::error_code ignored;
  fs::remove_all(path_, ignored);
  ::close(lock_fd_);
  lock_fd_ = -1;
}

}  // namespace omnipoint::io
