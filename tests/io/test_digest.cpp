// The hub's checksums (io/digest.h): SHA-256 and SHA-1 on the FIPS 180 examples, fed in pieces
// of every size across block boundaries, and Git's blob SHA-1 of a file.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "omnipoint/io/digest.h"
#include "support/scratch_dir.h"

namespace omnipoint::io {
namespace {

const std::string kTwoBlocks = "abcdbcdecdefdefgefghfghighijhijkijkljklmklmnlmnomnopnopq";

template <typename Hash>
std::string digest(const std::string& bytes) {
  Hash hash;
  hash.update(bytes);
  return hash.hex_digest();
}

TEST(Digest, Sha256OfTheStandardsExamples) {
  EXPECT_EQ(digest<Sha256>(""), "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855");
  EXPECT_EQ(digest<Sha256>("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
  EXPECT_EQ(digest<Sha256>(kTwoBlocks),
            "248d6a61d20638b8e5c026930c3e6039a33ce45964ff2167f6ecedd419db06c1");
  EXPECT_EQ(digest<Sha256>(std::string(1000000, 'a')),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0");
}

TEST(Digest, Sha1OfTheStandardsExamples) {
  EXPECT_EQ(digest<Sha1>(""), "da39a3ee5e6b4b0d3255bfef95601890afd80709");
  EXPECT_EQ(digest<Sha1>("abc"), "a9993e364706816aba3e25717850c26c9cd0d89d");
  EXPECT_EQ(digest<Sha1>(kTwoBlocks), "84983e441c3bd26ebaae4aa1f95129e5e54670f1");
  EXPECT_EQ(digest<Sha1>(std::string(1000000, 'a')), "34aa973cd4c4daa4f61eeb2bdbad27316534016f");
}

// The buffering: any split of the message gives the digest of the whole.
TEST(Digest, PiecesOfAnySizeGiveTheSameDigest) {
  std::string message;
  for (int i = 0; i < 300; ++i) message += static_cast<char>(i * 7 + 3);
  const std::string whole256 = digest<Sha256>(message), whole1 = digest<Sha1>(message);
  for (std::size_t piece : {1u, 3u, 55u, 56u, 63u, 64u, 65u, 127u, 200u}) {
    Sha256 sha256;
    Sha1 sha1;
    for (std::size_t at = 0; at < message.size(); at += piece) {
      sha256.update(message.substr(at, piece));
      sha1.update(message.substr(at, piece));
    }
    EXPECT_EQ(sha256.hex_digest(), whole256) << piece;
    EXPECT_EQ(sha1.hex_digest(), whole1) << piece;
  }
}

// `git hash-object` of a file holding "hello world\n", and sha256sum of it.
TEST(Digest, FilesHashAsGitAndSha256sumDo) {
  const auto dir = test::fresh_process_dir("omnipoint_digest");
  const std::string path = (dir / "hello.txt").string();
  std::ofstream(path, std::ios::binary) << "hello world\n";
  EXPECT_EQ(git_blob_sha1_of_file(path), "3b18e512dba79e4c8300dd08aeb37f8e728b8dad");
  EXPECT_EQ(sha256_of_file(path),
            "a948904f2f0f479b8f8197694b30184b0d2ed1c1cd2a1ec0fb85d299a192a447");
  EXPECT_THROW(sha256_of_file((dir / "missing").string()), std::runtime_error);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace omnipoint::io
