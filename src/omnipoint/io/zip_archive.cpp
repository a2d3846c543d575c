#include "omnipoint/io/zip_archive.h"

#include <cstdint>
#include <stdexcept>

namespace omnipoint::io {
namespace {

// Signatures (APPNOTE.TXT 4.3).
constexpr std::uint32_t kLocalHeader = 0x04034b50;
constexpr std::uint32_t kCentralHeader = 0x02014b50;
constexpr std::uint32_t kEndOfCentralDirectory = 0x06054b50;
constexpr std::uint32_t kZip64End = 0x06064b50;
constexpr std::uint32_t kZip64Locator = 0x07064b50;
constexpr std::size_t kEndSize = 22, kZip64LocatorSize = 20, kZip64EndSize = 56;
constexpr std::size_t kCentralSize = 46, kLocalSize = 30;
constexpr std::uint16_t kZip64Extra = 0x0001;

// Little-endian reads with their bounds checked against the whole buffer.
class Reader {
 public:
  Reader(const char* data, std::size_t size, const std::string& source)
      : data_(reinterpret_cast<const unsigned char*>(data)), size_(size), source_(source) {}

  std::uint64_t read(std::size_t at, int bytes) const {
    require(at, static_cast<std::size_t>(bytes), "a header");
    std::uint64_t value = 0;
    for (int i = bytes - 1; i >= 0; --i)
      value = value << 8 | data_[at + static_cast<std::size_t>(i)];
    return value;
  }
  std::uint16_t u16(std::size_t at) const { return static_cast<std::uint16_t>(read(at, 2)); }
  std::uint32_t u32(std::size_t at) const { return static_cast<std::uint32_t>(read(at, 4)); }
  std::uint64_t u64(std::size_t at) const { return read(at, 8); }

  // [at, at + length) inside the buffer, or a runtime_error saying what does not fit.
  void require(std::uint64_t at, std::uint64_t length, const char* what) const {
    if (at > size_ || length > size_ - at)
      fail(std::string(what) + " lies beyond the end of the file (truncated?)");
  }
  [[noreturn]] void fail(const std::string& problem) const {
    throw std::runtime_error(source_ + ": not a readable zip archive: " + problem);
  }
  std::size_t size() const { return size_; }
  const char* at(std::size_t offset) const { return reinterpret_cast<const char*>(data_ + offset); }

 private:
  const unsigned char* data_;
  std::size_t size_;
  const std::string& source_;
};

// The end-of-central-directory record: the last signature within the comment's reach.
std::size_t find_end_record(const Reader& in) {
  if (in.size() < kEndSize) in.fail("shorter than a zip's end record (truncated?)");
  const std::size_t lowest = in.size() > kEndSize + 0xFFFF ? in.size() - kEndSize - 0xFFFF : 0;
  for (std::size_t at = in.size() - kEndSize + 1; at-- > lowest;)
    if (in.u32(at) == kEndOfCentralDirectory) return at;
  in.fail("no end-of-central-directory record (truncated, or not a zip)");
}

}  // namespace

bool looks_like_zip(const char* data, std::size_t size) {
  if (size < 4) return false;
  const auto byte = [&](int i) { return static_cast<unsigned char>(data[i]); };
  return byte(0) == 'P' && byte(1) == 'K' &&
         ((byte(2) == 3 && byte(3) == 4) || (byte(2) == 5 && byte(3) == 6));
}

ZipArchive::ZipArchive(const char* data, std::size_t size, const std::string& source)
    : data_(data), source_(source) {
  const Reader in(data, size, source_);
  const std::size_t end = find_end_record(in);
  std::uint64_t count = in.u16(end + 10);
  std::uint64_t directory_size = in.u32(end + 12);
  std::uint64_t directory_offset = in.u32(end + 16);
  if (in.u16(end + 4) != 0 || in.u16(end + 6) != 0) in.fail("a multi-part archive");
  if (count == 0xFFFF || directory_size == 0xFFFFFFFF || directory_offset == 0xFFFFFFFF) {
    if (end < kZip64LocatorSize || in.u32(end - kZip64LocatorSize) != kZip64Locator)
      in.fail("zip64 sizes without a zip64 end-record locator");
    const std::uint64_t record = in.u64(end - kZip64LocatorSize + 8);
    in.require(record, kZip64EndSize, "the zip64 end record");
    if (in.u32(static_cast<std::size_t>(record)) != kZip64End) in.fail("a bad zip64 end record");
    const auto r = static_cast<std::size_t>(record);
    count = in.u64(r + 32);
    directory_size = in.u64(r + 40);
    directory_offset = in.u64(r + 48);
  }
  in.require(directory_offset, directory_size, "the central directory");
  // Each entry takes at least kCentralSize bytes of the directory.
  if (count > directory_size / kCentralSize) in.fail("more entries than the directory holds");

  std::size_t at = static_cast<std::size_t>(directory_offset);
  const std::size_t directory_end = at + static_cast<std::size_t>(directory_size);
  for (std::uint64_t i = 0; i < count; ++i) {
    if (at + kCentralSize > directory_end || in.u32(at) != kCentralHeader)
      in.fail("a bad central directory entry");
    const std::uint16_t flags = in.u16(at + 8), method = in.u16(at + 10);
    std::uint64_t compressed_size = in.u32(at + 20), size_field = in.u32(at + 24);
    const std::size_t name_length = in.u16(at + 28), extra_length = in.u16(at + 30),
                      comment_length = in.u16(at + 32);
    std::uint64_t local = in.u32(at + 42);
    const std::size_t name_at = at + kCentralSize, extra_at = name_at + name_length;
    const std::size_t next = extra_at + extra_length + comment_length;
    if (next > directory_end) in.fail("a central directory entry runs past the directory");
    const std::string name(in.at(name_at), name_length);

    // The zip64 extra field holds the 64-bit values of the fields set to 0xFFFFFFFF, in order.
    for (std::size_t e = extra_at; e + 4 <= extra_at + extra_length;) {
      const std::uint16_t id = in.u16(e), length = in.u16(e + 2);
      if (e + 4 + length > extra_at + extra_length) in.fail("a bad extra field in '" + name + "'");
      if (id == kZip64Extra) {
        std::size_t field = e + 4;
        const auto take = [&](std::uint64_t& value) {
          if (value != 0xFFFFFFFF) return;
          if (field + 8 > e + 4 + length) in.fail("a short zip64 field in '" + name + "'");
          value = in.u64(field);
          field += 8;
        };
        take(size_field);
        take(compressed_size);
        take(local);
      }
      e += 4 + length;
    }
    if (flags & 1) in.fail("'" + name + "' is encrypted");
    if (entries_.count(name)) in.fail("'" + name + "' appears twice");

    in.require(local, kLocalSize, "a local header");
    const auto local_at = static_cast<std::size_t>(local);
    if (in.u32(local_at) != kLocalHeader) in.fail("a bad local header for '" + name + "'");
    const std::uint64_t data_at =
        std::uint64_t{local_at} + kLocalSize + in.u16(local_at + 26) + in.u16(local_at + 28);
    if (method != 0) {
      entries_[name] = {0, 0, method};
    } else {
      if (compressed_size != size_field)
        in.fail("stored entry '" + name + "' has two different sizes");
      in.require(data_at, size_field, ("the data of '" + name + "'").c_str());
      entries_[name] = {static_cast<std::size_t>(data_at), static_cast<std::size_t>(size_field), 0};
    }
    at = next;
  }
}

const char* ZipArchive::data(const std::string& name, std::size_t* size) const {
  const auto found = entries_.find(name);
  if (found == entries_.end())
    throw std::runtime_error(source_ + ": the archive has no entry '" + name + "'");
  if (found->second.method != 0)
    throw std::runtime_error(source_ + ": entry '" + name + "' is compressed (method " +
                             std::to_string(found->second.method) +
                             "); only stored entries are read, as torch.save writes them");
  *size = found->second.size;
  return data_ + found->second.offset;
}

}  // namespace omnipoint::io
