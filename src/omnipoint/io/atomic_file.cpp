#include "omnipoint/io/atomic_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <memory>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <streambuf>
#include <vector>

namespace omnipoint::io {
namespace fs = std::filesystem;
namespace {

std::atomic<LargeFileWrites> large_writes{LargeFileWrites::direct};

// O_DIRECT wants the buffer's address, the file offset and the length aligned to the device's
// logical block; 4096 covers every block size in use. The buffer is a multiple of it.
constexpr std::size_t kAlignment = 4096;
constexpr std::size_t kBufferBytes = std::size_t{4} << 20;

[[noreturn]] void fail(const std::string& path, const char* what, int error) {
  throw std::runtime_error(path + ": " + what + ": " + std::strerror(error));
}

// A stream buffer over a file descriptor. The first time its buffer fills, the file is
// switched to O_DIRECT (when large writes are direct and the file system accepts it); from
// then on it writes whole buffers, and finish() writes the last partial block padded with
// zeros and truncates the padding away.
class FileWriter : public std::streambuf {
 public:
  FileWriter(int fd, std::string path)
      : fd_(fd),
        path_(std::move(path)),
        buffer_(static_cast<char*>(std::aligned_alloc(kAlignment, kBufferBytes)), std::free) {
    if (!buffer_) throw std::bad_alloc();
    setp(buffer_.get(), buffer_.get() + kBufferBytes);
  }

  WrittenFile finish() {
    const std::size_t tail = static_cast<std::size_t>(pptr() - pbase());
    if (!direct_) {
      write_out(tail);
      return {written_, used_direct_};
    }
    const std::uint64_t length = written_ + tail;
    const std::size_t padded = (tail + kAlignment - 1) / kAlignment * kAlignment;
    std::memset(buffer_.get() + tail, 0, padded - tail);
    write_out(padded);
    if (::ftruncate(fd_, static_cast<off_t>(length)) != 0) {
      fail(path_, "cannot set the file's length", errno);
    }
    return {length, used_direct_};
  }

 protected:
  int_type overflow(int_type ch) override {
    flush_full_buffer();
    if (traits_type::eq_int_type(ch, traits_type::eof())) return traits_type::not_eof(ch);
    *pptr() = traits_type::to_char_type(ch);
    pbump(1);
    return ch;
  }

  std::streamsize xsputn(const char* data, std::streamsize count) override {
    std::streamsize done = 0;
    while (done < count) {
      if (pptr() == epptr()) flush_full_buffer();
      const std::streamsize room = epptr() - pptr();
      const std::streamsize chunk = std::min(room, count - done);
      std::memcpy(pptr(), data + done, static_cast<std::size_t>(chunk));
      pbump(static_cast<int>(chunk));
      done += chunk;
    }
    return done;
  }

 private:
  void flush_full_buffer() {
    // The first full buffer decides: the file is larger than one buffer.
    if (written_ == 0 && large_writes.load() == LargeFileWrites::direct) set_direct(true);
    write_out(kBufferBytes);
    setp(buffer_.get(), buffer_.get() + kBufferBytes);
  }

  bool set_direct(bool on) {
    const int flags = ::fcntl(fd_, F_GETFL);
    if (flags < 0) return false;
    if (::fcntl(fd_, F_SETFL, on ? flags | O_DIRECT : flags & ~O_DIRECT) != 0) return false;
    direct_ = on;
    return true;
  }

  // Writes the first `size` bytes of the buffer at the file's end.
  void write_out(std::size_t size) {
    std::size_t done = 0;
    while (done < size) {
      const ssize_t n = ::write(fd_, buffer_.get() + done, size - done);
      if (n < 0) {
        if (errno == EINTR) continue;
        // Some file systems accept the flag and refuse the write: go on through the cache.
        if (errno == EINVAL && direct_ && set_direct(false)) continue;
        fail(path_, "write failed", errno);
      }
      if (n == 0) fail(path_, "write failed", ENOSPC);
      if (direct_) used_direct_ = true;
      done += static_cast<std::size_t>(n);
      written_ += static_cast<std::uint64_t>(n);
      // A short direct write leaves an unaligned offset: the rest goes through the cache.
      if (direct_ && (done % kAlignment != 0) && done < size) set_direct(false);
    }
  }

  int fd_;
  std::string path_;
  std::unique_ptr<char, decltype(&std::free)> buffer_;
  std::uint64_t written_ = 0;
  bool direct_ = false;
  bool used_direct_ = false;
};

}  // namespace

void set_large_file_writes(LargeFileWrites mode) {
  large_writes.store(mode);
}

LargeFileWrites large_file_writes() {
  return large_writes.load();
}

WrittenFile write_file_atomically(const std::string& path,
                                  const std::function<void(std::ostream&)>& write) {
  const fs::path target(path);
  const fs::path dir = target.has_parent_path() ? target.parent_path() : fs::path(".");
  if (!fs::is_directory(dir)) {
    throw std::runtime_error(path + ": output folder " + dir.string() + " does not exist");
  }
  std::string pattern = (dir / ("." + target.filename().string() + ".tmp-XXXXXX")).string();
  std::vector<char> name(pattern.begin(), pattern.end());
  name.push_back('\0');
  const int fd = ::mkstemp(name.data());
  if (fd < 0) {
    throw std::runtime_error(path + ": cannot create a temporary file: " + std::strerror(errno));
  }
  const std::string tmp(name.data());
  bool open = true;
  try {
    WrittenFile written;
    {
      FileWriter writer(fd, path);
      std::ostream out(&writer);
      // A failing write throws its own message (disk full) through the stream.
      out.exceptions(std::ios::badbit);
      write(out);
      written = writer.finish();
    }
    // mkstemp creates 0600; give the file the usual permissions.
    if (::fchmod(fd, S_IRUSR | S_IWUSR | S_IRGRP | S_IROTH) != 0) {
      fail(path, "cannot set the file's permissions", errno);
    }
    open = false;
    if (::close(fd) != 0) fail(path, "write failed", errno);
    fs::rename(tmp, target);
    return written;
  } catch (...) {
    if (open) ::close(fd);
    std::remove(tmp.c_str());
    throw;
  }
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open for reading");
  std::ostringstream buffer;
  buffer << in.rdbuf();
  if (in.bad()) throw std::runtime_error(path + ": read failed");
  return buffer.str();
}

}  // namespace omnipoint::io
