#pragma once
// A GLB file split into its glTF JSON and BIN chunks, the container checked on the way (header
// magic, version, total length, chunk types and lengths, 4-byte alignment): what the points
// and mesh writers' tests parse back.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdint>
#include <cstring>
#include <string>

namespace omnipoint::test {

inline uint32_t u32_at(const std::string& bytes, size_t offset) {
  uint32_t value;
  std::memcpy(&value, bytes.data() + offset, 4);
  return value;
}

// NOLINTNEXTLINE(bugprone-exception-escape): the implicit moves are those of its members.
struct GlbChunks {
  nlohmann::json gltf;
  std::string bin;  // empty when the file has no BIN chunk
};

inline GlbChunks parse_glb(const std::string& glb) {
  GlbChunks parsed;
  EXPECT_GE(glb.size(), 20u);
  if (glb.size() < 20) return parsed;
  EXPECT_EQ(glb.substr(0, 4), "glTF");
  EXPECT_EQ(u32_at(glb, 4), 2u);
  EXPECT_EQ(u32_at(glb, 8), glb.size());
  const uint32_t json_length = u32_at(glb, 12);
  EXPECT_EQ(u32_at(glb, 16), 0x4E4F534Au);  // "JSON"
  EXPECT_EQ(json_length % 4, 0u);
  parsed.gltf = nlohmann::json::parse(glb.substr(20, json_length));
  const size_t bin_header = 20 + json_length;
  if (bin_header == glb.size()) return parsed;
  const uint32_t bin_length = u32_at(glb, bin_header);
  EXPECT_EQ(u32_at(glb, bin_header + 4), 0x004E4942u);  // "BIN\0"
  EXPECT_EQ(bin_length % 4, 0u);
  EXPECT_EQ(bin_header + 8 + bin_length, glb.size());
  parsed.bin = glb.substr(bin_header + 8, bin_length);
  return parsed;
}

}  // namespace omnipoint::test
