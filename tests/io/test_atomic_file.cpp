#include <gtest/gtest.h>

#include <filesystem>
#include <ostream>
#include <stdexcept>

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
