#include "omnipoint/io/digest.h"

#include <openssl/evp.h>

#include <fstream>
#include <stdexcept>
#include <vector>

namespace omnipoint::io {
namespace {

// Feeds the file at `path` to `update` in 1 MiB chunks.
template <typename Update>
void read_chunks(const std::string& path, const Update& update) {
  std::ifstream file(path, std::ios::binary);
  if (!file) throw std::runtime_error(path + ": cannot open the file");
  std::vector<char> chunk(1 << 20);
  while (file) {
    file.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    if (file.gcount() > 0) update(chunk.data(), static_cast<std::size_t>(file.gcount()));
  }
  if (!file.eof()) throw std::runtime_error(path + ": cannot read the file");
}

}  // namespace

MessageDigest::MessageDigest(const evp_md_st* algorithm) : context_(EVP_MD_CTX_new()) {
  if (context_ == nullptr || EVP_DigestInit_ex(context_, algorithm, nullptr) != 1) {
    EVP_MD_CTX_free(context_);
    throw std::runtime_error("OpenSSL: cannot start a digest");
  }
}

MessageDigest::~MessageDigest() {
  EVP_MD_CTX_free(context_);
}

void MessageDigest::update(const void* data, std::size_t size) {
  if (EVP_DigestUpdate(context_, data, size) != 1)
    throw std::runtime_error("OpenSSL: a digest update failed");
}

std::string MessageDigest::hex_digest() {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  if (EVP_DigestFinal_ex(context_, digest, &size) != 1)
    throw std::runtime_error("OpenSSL: a digest could not be finished");
  static const char* const kHex = "0123456789abcdef";
  std::string text;
  text.reserve(2 * static_cast<std::size_t>(size));
  for (unsigned int i = 0; i < size; ++i) {
    text += kHex[digest[i] >> 4];
    text += kHex[digest[i] & 15];
  }
  return text;
}

Sha256::Sha256() : MessageDigest(EVP_sha256()) {}
Sha1::Sha1() : MessageDigest(EVP_sha1()) {}

std::string sha256_of_file(const std::string& path) {
  Sha256 hash;
  read_chunks(path, [&](const char* data, std::size_t size) { hash.update(data, size); });
  return hash.hex_digest();
}

std::string git_blob_sha1_of_file(const std::string& path) {
  Sha1 hash;
  std::uintmax_t size = 0;
  {
    std::ifstream file(path, std::ios::binary | std::ios::ate);
    if (!file) throw std::runtime_error(path + ": cannot open the file");
    size = static_cast<std::uintmax_t>(file.tellg());
  }
  const std::string header = "blob " + std::to_string(size);
  hash.update(header.c_str(), header.size() + 1);  // with its terminating NUL
  read_chunks(path, [&](const char* data, std::size_t chunk) { hash.update(data, chunk); });
  return hash.hex_digest();
}

}  // namespace omnipoint::io
