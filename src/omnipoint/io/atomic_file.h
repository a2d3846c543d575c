#pragma once
// Atomic file output: a failed write never leaves a half-written file behind.
#include <functional>
#include <iosfwd>
#include <string>

namespace omnipoint::io {

// Streams the content produced by `write` into a temporary file in the destination's
// folder, flushes it, then renames it over `path`. If `write` throws or the stream
// fails, the temporary file is removed and the error is rethrown; `path` is untouched.
void write_file_atomically(const std::string& path,
                           const std::function<void(std::ostream&)>& write);

// Reads a whole file into memory; throws std::runtime_error naming the path on failure.
std::string read_file(const std::string& path);

}  // namespace omnipoint::io
