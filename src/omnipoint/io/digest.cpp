// SHA-256 and SHA-1 after FIPS 180-4: both hash 64-byte blocks of a message padded with a 1 bit,
// zeros and its bit length as a big-endian 64-bit number.
#include "omnipoint/io/digest.h"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <stdexcept>
#include <vector>

namespace omnipoint::io {

namespace {

std::uint32_t rotr(std::uint32_t x, int n) {
  return (x >> n) | (x << (32 - n));
}
std::uint32_t rotl(std::uint32_t x, int n) {
  return (x << n) | (x >> (32 - n));
}
std::uint32_t big_endian(const std::uint8_t* p) {
  return (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) | (std::uint32_t{p[2]} << 8) |
         std::uint32_t{p[3]};
}

// The buffering both hashes share: whole blocks go to `block`, the rest waits in `buffer`.
template <typename Block>
void feed(std::array<std::uint8_t, 64>& buffer, std::size_t& buffered, std::uint64_t& length,
          const void* data, std::size_t size, const Block& block) {
  const auto* bytes = static_cast<const std::uint8_t*>(data);
  length += size;
  while (size > 0) {
    if (buffered == 0 && size >= 64) {
      block(bytes);
      bytes += 64;
      size -= 64;
      continue;
    }
    const std::size_t take = std::min(size, 64 - buffered);
    std::copy(bytes, bytes + take, buffer.begin() + static_cast<std::ptrdiff_t>(buffered));
    buffered += take;
    bytes += take;
    size -= take;
    if (buffered == 64) {
      block(buffer.data());
      buffered = 0;
    }
  }
}

// The padding: 0x80, zeros up to 56 bytes of the last block, the length in bits.
template <typename Block>
void finish(std::array<std::uint8_t, 64>& buffer, std::size_t& buffered, std::uint64_t length,
            const Block& block) {
  const std::uint64_t bits = length * 8;
  buffer[buffered++] = 0x80;
  if (buffered > 56) {
    std::fill(buffer.begin() + static_cast<std::ptrdiff_t>(buffered), buffer.end(), 0);
    block(buffer.data());
    buffered = 0;
  }
  std::fill(buffer.begin() + static_cast<std::ptrdiff_t>(buffered), buffer.begin() + 56, 0);
  for (int i = 0; i < 8; ++i) buffer[56 + i] = static_cast<std::uint8_t>(bits >> (56 - 8 * i));
  block(buffer.data());
  buffered = 0;
}

template <std::size_t N>
std::string hex(const std::array<std::uint32_t, N>& words) {
  std::string text;
  char digits[9];
  for (std::uint32_t word : words) {
    std::snprintf(digits, sizeof digits, "%08x", word);
    text += digits;
  }
  return text;
}

constexpr std::array<std::uint32_t, 64> kSha256Rounds = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5,
    0xd807aa98, 0x12835b01, 0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174,
    0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc, 0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da,
    0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147, 0x06ca6351, 0x14292967,
    0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070,
    0x19a4c116, 0x1e376c08, 0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3,
    0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208, 0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

// Reads `path` in chunks into `update`.
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

Sha256::Sha256()
    : state_{0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a,
             0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19} {}

void Sha256::block(const std::uint8_t* data) {
  std::array<std::uint32_t, 64> w;
  for (int i = 0; i < 16; ++i) w[i] = big_endian(data + 4 * i);
  for (int i = 16; i < 64; ++i) {
    const std::uint32_t s0 = rotr(w[i - 15], 7) ^ rotr(w[i - 15], 18) ^ (w[i - 15] >> 3);
    const std::uint32_t s1 = rotr(w[i - 2], 17) ^ rotr(w[i - 2], 19) ^ (w[i - 2] >> 10);
    w[i] = w[i - 16] + s0 + w[i - 7] + s1;
  }
  std::uint32_t a = state_[0], b = state_[1], c = state_[2], d = state_[3], e = state_[4],
                f = state_[5], g = state_[6], h = state_[7];
  for (int i = 0; i < 64; ++i) {
    const std::uint32_t sum1 = rotr(e, 6) ^ rotr(e, 11) ^ rotr(e, 25);
    const std::uint32_t choose = (e & f) ^ (~e & g);
    const std::uint32_t t1 = h + sum1 + choose + kSha256Rounds[i] + w[i];
    const std::uint32_t sum0 = rotr(a, 2) ^ rotr(a, 13) ^ rotr(a, 22);
    const std::uint32_t majority = (a & b) ^ (a & c) ^ (b & c);
    const std::uint32_t t2 = sum0 + majority;
    h = g;
    g = f;
    f = e;
    e = d + t1;
    d = c;
    c = b;
    b = a;
    a = t1 + t2;
  }
  state_[0] += a;
  state_[1] += b;
  state_[2] += c;
  state_[3] += d;
  state_[4] += e;
  state_[5] += f;
  state_[6] += g;
  state_[7] += h;
}

void Sha256::update(const void* data, std::size_t size) {
  feed(buffer_, buffered_, length_, data, size, [this](const std::uint8_t* b) { block(b); });
}

std::string Sha256::hex_digest() {
  finish(buffer_, buffered_, length_, [this](const std::uint8_t* b) { block(b); });
  return hex(state_);
}

Sha1::Sha1() : state_{0x67452301, 0xefcdab89, 0x98badcfe, 0x10325476, 0xc3d2e1f0} {}

void Sha1::block(const std::uint8_t* data) {
  std::array<std::uint32_t, 80> w;
  for (int i = 0; i < 16; ++i) w[i] = big_endian(data + 4 * i);
  for (int i = 16; i < 80; ++i) w[i] = rotl(w[i - 3] ^ w[i - 8] ^ w[i - 14] ^ w[i - 16], 1);
  std::uint32_t a = state_[0], b = state_[1], c = state_[2], d = state_[3], e = state_[4];
  for (int i = 0; i < 80; ++i) {
    std::uint32_t f, k;
    if (i < 20) {
      f = (b & c) | (~b & d);
      k = 0x5a827999;
    } else if (i < 40) {
      f = b ^ c ^ d;
      k = 0x6ed9eba1;
    } else if (i < 60) {
      f = (b & c) | (b & d) | (c & d);
      k = 0x8f1bbcdc;
    } else {
      f = b ^ c ^ d;
      k = 0xca62c1d6;
    }
    const std::uint32_t t = rotl(a, 5) + f + e + k + w[i];
    e = d;
    d = c;
    c = rotl(b, 30);
    b = a;
    a = t;
  }
  state_[0] += a;
  state_[1] += b;
  state_[2] += c;
  state_[3] += d;
  state_[4] += e;
}

void Sha1::update(const void* data, std::size_t size) {
  feed(buffer_, buffered_, length_, data, size, [this](const std::uint8_t* b) { block(b); });
}

std::string Sha1::hex_digest() {
  finish(buffer_, buffered_, length_, [this](const std::uint8_t* b) { block(b); });
  return hex(state_);
}

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
