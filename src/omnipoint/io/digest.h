#pragma once
// The checksums the Hugging Face hub gives its files (io/hub.h): SHA-256 of an LFS file's
// content, and Git's blob SHA-1 of a small file (SHA-1 of "blob <size>\0" and the content),
// computed by OpenSSL's libcrypto. Streaming: update() any number of times, then hex_digest()
// once.
#include <cstddef>
#include <string>

struct evp_md_ctx_st;  // OpenSSL's EVP_MD_CTX
struct evp_md_st;      // OpenSSL's EVP_MD

namespace omnipoint::io {

class MessageDigest {
 public:
  MessageDigest(const MessageDigest&) = delete;
  MessageDigest& operator=(const MessageDigest&) = delete;
  ~MessageDigest();
  void update(const void* data, std::size_t size);
  void update(const std::string& bytes) { update(bytes.data(), bytes.size()); }
  // The digest as lowercase hex digits; the hasher is spent afterwards.
  std::string hex_digest();

 protected:
  explicit MessageDigest(const evp_md_st* algorithm);

 private:
  evp_md_ctx_st* context_;
};

class Sha256 : public MessageDigest {
 public:
  Sha256();
};

class Sha1 : public MessageDigest {
 public:
  Sha1();
};

// A file's SHA-256, and its Git blob SHA-1, as hex; std::runtime_error naming the path when it
// cannot be read.
std::string sha256_of_file(const std::string& path);
std::string git_blob_sha1_of_file(const std::string& path);

}  // namespace omnipoint::io
