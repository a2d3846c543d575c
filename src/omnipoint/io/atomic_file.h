#pragma once
// Atomic file output: a failed write never leaves a half-written file behind.
#include <cstdint>
#include <functional>
#include <iosfwd>
#include <string>

namespace omnipoint::io {

// How a file larger than the writer's 4 MiB buffer goes to disk.
//  - direct: whole aligned blocks with O_DIRECT, past the page cache. The default: on the
//    development VM a page-cache page costs a host fault, and buffered writing ran ~4x below
//    the disk's rate (docs/PERFORMANCE.md, "Direct writes").
//  - page_cache: ordinary buffered writes, which return before the data reaches the disk;
//    better for one large output on a slow disk (SD card, eMMC, network file system).
// File systems that refuse O_DIRECT are written through the page cache either way, and so are
// smaller files.
enum class LargeFileWrites { direct, page_cache };
void set_large_file_writes(LargeFileWrites mode);  // process-wide
LargeFileWrites large_file_writes();

// What write_file_atomically did.
struct WrittenFile {
  std::uint64_t bytes = 0;
  bool direct = false;  // some of it went out with O_DIRECT
};

// Streams the content produced by `write` into a temporary file in the destination's
// folder, then renames it over `path`. If `write` throws or a write fails (disk full), the
// temporary file is removed and the error is rethrown; `path` is untouched.
WrittenFile write_file_atomically(const std::string& path,
                                  const std::function<void(std::ostream&)>& write);

// Reads a whole file into memory; throws std::runtime_error naming the path on failure.
std::string read_file(const std::string& path);

}  // namespace omnipoint::io
