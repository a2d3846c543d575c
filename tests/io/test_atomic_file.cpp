#include <fcntl.h>
#include <gtest/gtest.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <csignal>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <ostream>
#include <stdexcept>
#include <string>

#include "omnipoint/io/atomic_file.h"

namespace fs = std::filesystem;
using omnipoint::io::read_file;
using omnipoint::io::write_file_atomically;

TEST(AtomicFile, WritesAndReplaces) {
  const fs::path dir = fs::temp_directory_path() / "omnipoint_atomic_test";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = (dir / "x.txt").string();
  write_file_atomically(path, [](std::ostream& out) { out << "first"; });
  EXPECT_EQ(read_file(path), "first");
  write_file_atomically(path, [](std::ostream& out) { out << "second"; });
  EXPECT_EQ(read_file(path), "second");
  fs::remove_all(dir);
}

TEST(AtomicFile, FailureLeavesNothingHalfWritten) {
  const fs::path dir = fs::temp_directory_path() / "omnipoint_atomic_fail";
  fs::remove_all(dir);
  fs::create_directories(dir);
  const std::string path = (dir / "x.txt").string();
  write_file_atomically(path, [](std::ostream& out) { out << "kept"; });
  EXPECT_THROW(write_file_atomically(path,
                                     [](std::ostream& out) {
                                       out << "partial";
                                       throw std::runtime_error("writer failed");
                                     }),
               std::runtime_error);
  EXPECT_EQ(read_file(path), "kept");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir), fs::directory_iterator()), 1);
  EXPECT_THROW(read_file((dir / "absent").string()), std::runtime_error);
  fs::remove_all(dir);
}

namespace {

// A scratch folder of the test's own, removed at the end.
struct ScratchFolder {
  explicit ScratchFolder(const std::string& name) : path(fs::temp_directory_path() / name) {
    fs::remove_all(path);
    fs::create_directories(path);
  }
  ~ScratchFolder() { fs::remove_all(path); }
  fs::path path;
};

// Whether the folder's file system takes O_DIRECT writes (tmpfs before Linux 6.6 does not).
bool takes_direct_writes(const fs::path& folder) {
  const std::string probe = (folder / "probe").string();
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_DIRECT, 0600);
  if (fd < 0) return false;
  void* block = std::aligned_alloc(4096, 4096);
  std::memset(block, 0, 4096);
  const bool ok = ::write(fd, block, 4096) == 4096;
  std::free(block);
  ::close(fd);
  fs::remove(probe);
  return ok;
}

// Bytes that differ from block to block, so a misplaced or repeated block shows.
std::string pattern(std::size_t size) {
  std::string bytes(size, '\0');
  std::uint32_t state = 12345;
  for (char& b : bytes) {
    state = state * 1664525u + 1013904223u;
    b = static_cast<char>(state >> 24);
  }
  return bytes;
}

// Writes `bytes` the way the project's writers do: a header, single characters, a large block.
void write_in_pieces(std::ostream& out, const std::string& bytes) {
  const std::size_t head = std::min<std::size_t>(bytes.size(), 100);
  out.write(bytes.data(), static_cast<std::streamsize>(head));
  const std::size_t singles = std::min<std::size_t>(bytes.size() - head, 3);
  for (std::size_t i = 0; i < singles; ++i) out.put(bytes[head + i]);
  out.write(bytes.data() + head + singles,
            static_cast<std::streamsize>(bytes.size() - head - singles));
}

constexpr std::size_t kMiB = std::size_t{1} << 20;

}  // namespace

TEST(AtomicFile, EveryLengthRoundTripsAroundTheBufferAndBlockEdges) {
  ScratchFolder dir("omnipoint_atomic_lengths");
  const bool direct_here = takes_direct_writes(dir.path);
  ASSERT_EQ(omnipoint::io::large_file_writes(), omnipoint::io::LargeFileWrites::direct);
  for (const std::size_t size :
       {std::size_t{0}, std::size_t{1}, std::size_t{4095}, std::size_t{4096}, 4 * kMiB - 1,
        4 * kMiB, 4 * kMiB + 1, 4 * kMiB + 4096, 9 * kMiB + 4097}) {
    SCOPED_TRACE(size);
    const std::string bytes = pattern(size);
    const std::string path = (dir.path / "file.bin").string();
    const auto written =
        write_file_atomically(path, [&](std::ostream& out) { write_in_pieces(out, bytes); });
    EXPECT_EQ(written.bytes, size);
    EXPECT_EQ(fs::file_size(path), size);
    EXPECT_TRUE(read_file(path) == bytes);
    // Files within one buffer are written through the cache; larger ones directly here.
    EXPECT_EQ(written.direct, direct_here && size > 4 * kMiB);
    EXPECT_EQ(fs::status(path).permissions() & fs::perms::all,
              fs::perms::owner_read | fs::perms::owner_write | fs::perms::group_read |
                  fs::perms::others_read);
  }
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path), fs::directory_iterator()), 1);
  if (!direct_here) GTEST_SKIP() << dir.path << " does not take O_DIRECT: cached writes only";
}

TEST(AtomicFile, PageCacheModeNeverWritesDirectly) {
  ScratchFolder dir("omnipoint_atomic_cached");
  const std::string bytes = pattern(6 * kMiB + 7);
  const std::string path = (dir.path / "file.bin").string();
  omnipoint::io::set_large_file_writes(omnipoint::io::LargeFileWrites::page_cache);
  const auto written =
      write_file_atomically(path, [&](std::ostream& out) { write_in_pieces(out, bytes); });
  omnipoint::io::set_large_file_writes(omnipoint::io::LargeFileWrites::direct);
  EXPECT_FALSE(written.direct);
  EXPECT_TRUE(read_file(path) == bytes);
}

TEST(AtomicFile, AWriterFailingAfterDirectBlocksLeavesNothing) {
  ScratchFolder dir("omnipoint_atomic_direct_fail");
  const std::string path = (dir.path / "file.bin").string();
  write_file_atomically(path, [](std::ostream& out) { out << "kept"; });
  const std::string bytes = pattern(9 * kMiB);
  EXPECT_THROW(write_file_atomically(path,
                                     [&](std::ostream& out) {
                                       write_in_pieces(out, bytes);
                                       throw std::runtime_error("writer failed");
                                     }),
               std::runtime_error);
  EXPECT_EQ(read_file(path), "kept");
  EXPECT_EQ(std::distance(fs::directory_iterator(dir.path), fs::directory_iterator()), 1);
}

TEST(AtomicFile, AFailingWriteIsOneClearErrorAndLeavesNothing) {
  // A file-size limit makes the disk refuse the write, as a full disk does (EFBIG for ENOSPC).
  ScratchFolder dir("omnipoint_atomic_refused");
  const std::string path = (dir.path / "file.bin").string();
  rlimit old{};
  ASSERT_EQ(::getrlimit(RLIMIT_FSIZE, &old), 0);
  rlimit small = old;
  small.rlim_cur = 5 * kMiB;
  const auto old_handler = std::signal(SIGXFSZ, SIG_IGN);
  ASSERT_EQ(::setrlimit(RLIMIT_FSIZE, &small), 0);
  std::string message;
  for (const std::size_t size : {6 * kMiB, 12 * kMiB}) {
    const std::string bytes = pattern(size);
    try {
      write_file_atomically(path, [&](std::ostream& out) { write_in_pieces(out, bytes); });
    } catch (const std::runtime_error& e) {
      message = e.what();
    }
    EXPECT_NE(message.find(path + ": write failed: File too large"), std::string::npos) << message;
    message.clear();
  }
  ::setrlimit(RLIMIT_FSIZE, &old);
  std::signal(SIGXFSZ, old_handler);
  EXPECT_FALSE(fs::exists(path));
  EXPECT_TRUE(fs::is_empty(dir.path));
}
