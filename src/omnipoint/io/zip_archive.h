#pragma once
// The entries of a zip archive held in memory, read in place: what PyTorch's torch.save
// (>= 1.6) writes, an uncompressed ("stored") zip whose records are aligned for in-place use.
// Only stored entries are readable (torch.save never compresses); zip64 sizes and offsets are
// understood. The CRCs are not verified: checking 1 GB of weights would cost a second of every
// model load, and every size and offset is checked against the buffer instead.
#include <cstddef>
#include <map>
#include <string>

namespace omnipoint::io {

class ZipArchive {
 public:
  struct Entry {
    std::size_t offset = 0;  // of the entry's data in the buffer (stored entries)
    std::size_t size = 0;
    int method = 0;  // 0: stored, readable; anything else is compressed
  };

  // Indexes the archive's central directory. std::runtime_error naming `source` for anything
  // that is not a well-formed zip whose entries lie inside the buffer. The buffer must outlive
  // the archive.
  ZipArchive(const char* data, std::size_t size, const std::string& source);

  const std::map<std::string, Entry>& entries() const { return entries_; }
  bool contains(const std::string& name) const { return entries_.count(name) != 0; }
  // A stored entry's bytes; std::runtime_error naming the entry if it is absent or compressed.
  const char* data(const std::string& name, std::size_t* size) const;

 private:
  const char* data_;
  std::string source_;
  std::map<std::string, Entry> entries_;
};

// Whether `data` starts like a zip archive (a local file header or an empty archive's end).
bool looks_like_zip(const char* data, std::size_t size);

}  // namespace omnipoint::io
