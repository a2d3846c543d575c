#pragma once
// The checksums the Hugging Face hub gives its files (io/hub.h): SHA-256 (FIPS 180-4) of an LFS
// file's content, and Git's blob SHA-1 of a small file (SHA-1 of "blob <size>\0" and the
// content). Streaming: update() any number of times, then hex_digest() once.
#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace omnipoint::io {

class Sha256 {
 public:
  Sha256();
  void update(const void* data, std::size_t size);
  void update(const std::string& bytes) { update(bytes.data(), bytes.size()); }
  // The digest as 64 lowercase hex digits; the hasher is spent afterwards.
  std::string hex_digest();

 private:
  void block(const std::uint8_t* data);
  std::array<std::uint32_t, 8> state_;
  std::array<std::uint8_t, 64> buffer_{};
  std::size_t buffered_ = 0;
  std::uint64_t length_ = 0;  // bytes so far
};

class Sha1 {
 public:
  Sha1();
  void update(const void* data, std::size_t size);
  void update(const std::string& bytes) { update(bytes.data(), bytes.size()); }
  // The digest as 40 lowercase hex digits; the hasher is spent afterwards.
  std::string hex_digest();

 private:
  void block(const std::uint8_t* data);
  std::array<std::uint32_t, 5> state_;
  std::array<std::uint8_t, 64> buffer_{};
  std::size_t buffered_ = 0;
  std::uint64_t length_ = 0;
};

// A file's SHA-256, and its Git blob SHA-1, as hex; std::runtime_error naming the path when it
// cannot be read.
std::string sha256_of_file(const std::string& path);
std::string git_blob_sha1_of_file(const std::string& path);

}  // namespace omnipoint::io
