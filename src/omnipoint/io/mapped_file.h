#pragma once
// Read-only memory map of a whole file: large weights files are parsed in place instead of
// being copied into a string first.
#include <cstddef>
#include <string>

namespace omnipoint::io {

class MappedFile {
 public:
  enum class Access {
    kReadOnly,     // writing to the pages faults
    kCopyOnWrite,  // writable pages; a written page becomes private, the file never changes
  };
  // Maps `path`; throws std::runtime_error naming the path if it cannot be opened or mapped.
  explicit MappedFile(const std::string& path, Access access = Access::kReadOnly);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;

  const char* data() const { return static_cast<const char*>(address_); }
  std::size_t size() const { return size_; }

 private:
  void* address_ = nullptr;  // null for an empty file (mmap cannot map 0 bytes)
  std::size_t size_ = 0;
};

}  // namespace omnipoint::io
