// The digests of a build without the hub (OMNIPOINT_WITH_HUB=OFF: no libcurl, no libcrypto):
// nothing is downloaded, so nothing is verified; a call says so.
#include <stdexcept>

#include "omnipoint/io/digest.h"

namespace omnipoint::io {
namespace {

[[noreturn]] void unavailable() {
  throw std::runtime_error(
      "checksums: this build has no hub support (configured with OMNIPOINT_WITH_HUB=OFF)");
}

}  // namespace

MessageDigest::MessageDigest(const evp_md_st* /*algorithm*/) : context_(nullptr) {
  unavailable();
}
MessageDigest::~MessageDigest() = default;
void MessageDigest::update(const void* /*data*/, std::size_t /*size*/) {
  unavailable();
}
std::string MessageDigest::hex_digest() {
  unavailable();
}
Sha256::Sha256() : MessageDigest(nullptr) {}
Sha1::Sha1() : MessageDigest(nullptr) {}
std::string sha256_of_file(const std::string& /*path*/) {
  unavailable();
}
std::string git_blob_sha1_of_file(const std::string& /*path*/) {
  unavailable();
}

}  // namespace omnipoint::io
