#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "omnipoint/io/ply.h"

namespace fs = std::filesystem;
using omnipoint::io::parse_ply;
using omnipoint::io::read_ply;
using omnipoint::io::write_ply;

namespace {

fs::path temp_dir() {
  const fs::path dir = fs::temp_directory_path() / ("omnipoint_ply_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir;
}

template <typename T>
void append(std::string& s, T v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof(v));
}

void expect_error(const std::string& bytes, const std::string& fragment) {
  try {
    parse_ply(bytes, "cloud.ply");
    FAIL() << "no error for: " << fragment;
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("cloud.ply"), std::string::npos) << e.what();
  }
}

}  // namespace

TEST(Ply, BinaryRoundTripWithAndWithoutColours) {
  const auto dir = temp_dir();
  auto g = at::make_generator<at::CPUGeneratorImpl>(5);
  auto points = at::randn({1000, 3}, g, at::kDouble) * 10;
  auto colors = at::randint(0, 256, {1000, 3}, g, at::kByte);
  write_ply((dir / "c.ply").string(), points, colors);
  auto back = read_ply((dir / "c.ply").string());
  EXPECT_TRUE(at::equal(back.points, points.to(at::kFloat)));
  EXPECT_TRUE(at::equal(back.colors, colors));
  write_ply((dir / "p.ply").string(), points.to(at::kFloat));
  auto plain = read_ply((dir / "p.ply").string());
  EXPECT_TRUE(at::equal(plain.points, points.to(at::kFloat)));
  EXPECT_FALSE(plain.colors.defined());
  // Header as documented and exact size: 15 bytes per coloured vertex.
  const auto size = fs::file_size(dir / "c.ply");
  std::ifstream in(dir / "c.ply", std::ios::binary);
  std::string first;
  std::getline(in, first);
  EXPECT_EQ(first, "ply");
  const std::string header =
      "ply\nformat binary_little_endian 1.0\ncomment written by OmniPoint\nelement vertex 1000\n"
      "property float x\nproperty float y\nproperty float z\nproperty uchar red\nproperty uchar "
      "green\n"
      "property uchar blue\nend_header\n";
  EXPECT_EQ(size, header.size() + size_t{15} * 1000);
  // An empty cloud is a valid file.
  write_ply((dir / "e.ply").string(), at::zeros({0, 3}));
  EXPECT_EQ(read_ply((dir / "e.ply").string()).points.size(0), 0);
  fs::remove_all(dir);
}

TEST(Ply, ReadsAsciiWithExtraProperties) {
  const std::string text =
      "ply\r\nformat ascii 1.0\r\ncomment from another tool\r\nelement vertex 2\r\n"
      "property double x\r\nproperty double y\r\nproperty double z\r\nproperty float nx\r\n"
      "property uchar red\r\nproperty uchar green\r\nproperty uchar blue\r\n"
      "element face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n"
      "1.5 -2 3e2 0.1 255 0 7\r\n-0.25 0 1 0 1 2 3\r\n3 0 1 1\r\n";
  auto cloud = parse_ply(text);
  EXPECT_TRUE(
      at::equal(cloud.points, at::tensor({1.5f, -2.0f, 300.0f, -0.25f, 0.0f, 1.0f}).view({2, 3})));
  EXPECT_TRUE(at::equal(cloud.colors, at::tensor({255, 0, 7, 1, 2, 3}, at::kByte).view({2, 3})));
}

TEST(Ply, ReadsBinaryWithMixedTypes) {
  std::string bytes =
      "ply\nformat binary_little_endian 1.0\nelement vertex 2\nproperty int16 id\n"
      "property double x\nproperty double y\nproperty double z\nproperty uint8 red\n"
      "property uint8 green\nproperty uint8 blue\nproperty float32 intensity\nend_header\n";
  for (int i = 0; i < 2; ++i) {
    append<std::int16_t>(bytes, static_cast<std::int16_t>(i));
    append<double>(bytes, 0.1 * (i + 1));
    append<double>(bytes, -2.0);
    append<double>(bytes, 1e3);
    append<std::uint8_t>(bytes, 10);
    append<std::uint8_t>(bytes, 20);
    append<std::uint8_t>(bytes, static_cast<std::uint8_t>(30 + i));
    append<float>(bytes, 0.5f);
  }
  auto cloud = parse_ply(bytes);
  EXPECT_TRUE(at::equal(cloud.points,
                        at::tensor({0.1f, -2.0f, 1000.0f, 0.2f, -2.0f, 1000.0f}).view({2, 3})));
  EXPECT_TRUE(
      at::equal(cloud.colors, at::tensor({10, 20, 30, 10, 20, 31}, at::kByte).view({2, 3})));
}

TEST(Ply, RejectsUnsupportedAndMalformedFiles) {
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  expect_error("PLY\n", "does not start with 'ply'");
  expect_error("ply\nformat binary_little_endian 1.0\nelement vertex 1\n" + xyz, "no end_header");
  expect_error("ply\nformat binary_big_endian 1.0\nelement vertex 1\n" + xyz + "end_header\n",
               "binary_big_endian");
  expect_error("ply\nformat ascii 2.0\nelement vertex 1\n" + xyz + "end_header\n", "version");
  expect_error("ply\nelement vertex 1\n" + xyz + "end_header\n1 2 3\n", "no format");
  expect_error("ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int v\nend_header\n",
               "expected vertex");
  expect_error("ply\nformat ascii 1.0\nelement vertex -1\n" + xyz + "end_header\n",
               "bad vertex count");
  expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty list uchar float x\nend_header\n",
               "list property");
  expect_error("ply\nformat ascii 1.0\nelement vertex 1\nproperty half x\nend_header\n",
               "unknown property type");
  expect_error(
      "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 "
      "2\n",
      "x, y, z");
  expect_error("ply\nformat ascii 1.0\nelement vertex 1\n" + xyz +
                   "property float red\nproperty float green\n"
                   "property float blue\nend_header\n1 2 3 0.5 0.5 0.5\n",
               "uchar");
  expect_error("ply\nformat ascii 1.0\nelement vertex 2\n" + xyz + "end_header\n1 2 3\n4 5 x\n",
               "bad or missing value 'x'");
  expect_error("ply\nformat ascii 1.0\nelement vertex 2\n" + xyz + "end_header\n1 2 3\n4 5      \n",
               "bad or missing value");
  expect_error("ply\nformat ascii 1.0\nelement vertex 1\n" + xyz +
                   "property uchar red\nproperty uchar green\n"
                   "property uchar blue\nend_header\n1 2 3 4 5 300\n",
               "colour outside");
  expect_error("ply\nformat binary_little_endian 1.0\nelement vertex 2\n" + xyz + "end_header\n" +
                   std::string(20, '\0'),
               "truncated");
  expect_error(
      "ply\nformat binary_little_endian 1.0\nelement vertex 999999999999\n" + xyz + "end_header\n",
      "truncated");
  expect_error("ply\nformat ascii 1.0\nfoo\nend_header\n", "unknown header line");
  EXPECT_THROW(read_ply("/nonexistent/cloud.ply"), std::runtime_error);
}

TEST(Ply, WriterRejectsBadInputsAndLeavesNoFile) {
  const auto dir = temp_dir();
  const auto path = (dir / "bad.ply").string();
  EXPECT_THROW(write_ply(path, at::zeros({4, 2})), std::invalid_argument);
  EXPECT_THROW(write_ply(path, at::zeros({4, 3}, at::kInt)), std::invalid_argument);
  EXPECT_THROW(write_ply(path, at::zeros({4, 3}), at::zeros({4, 3})), std::invalid_argument);
  EXPECT_THROW(write_ply(path, at::full({1, 3}, NAN)), std::invalid_argument);
  EXPECT_FALSE(fs::exists(path));
  EXPECT_THROW(write_ply((dir / "missing" / "x.ply").string(), at::zeros({1, 3})),
               std::runtime_error);
  fs::remove_all(dir);
}

TEST(Ply, MutatedFilesFailCleanly) {
  // Random byte flips and truncations of valid files: parse or throw runtime_error, never
  // crash (run under ASan/UBSan, see the sanitizer build in the report).
  std::string binary =
      "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n"
      "property float y\nproperty double z\nproperty uchar red\nproperty uchar green\n"
      "property uchar blue\nend_header\n";
  for (int i = 0; i < 3; ++i) {
    append<float>(binary, 1.0f * i);
    append<float>(binary, 2.0f);
    append<double>(binary, 3.0);
    binary.append("\x01\x02\x03", 3);
  }
  const std::string ascii =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
      "end_header\n1 2 3 4 5 6\n7 8 9 10 11 12\n";
  auto g = at::make_generator<at::CPUGeneratorImpl>(99);
  for (const std::string& original : {binary, ascii}) {
    ASSERT_NO_THROW(parse_ply(original));
    for (int trial = 0; trial < 500; ++trial) {
      std::string bytes = original;
      const auto draw = [&](int64_t n) {
        return at::randint(n, {1}, g, at::kLong).item<int64_t>();
      };
      for (int k = 0, flips = static_cast<int>(draw(4)) + 1; k < flips; ++k) {
        bytes[static_cast<std::size_t>(draw(static_cast<int64_t>(bytes.size())))] =
            static_cast<char>(draw(256));
      }
      if (trial % 3 == 0)
        bytes.resize(static_cast<std::size_t>(draw(static_cast<int64_t>(bytes.size()) + 1)));
      try {
        const auto cloud = parse_ply(bytes);
        EXPECT_EQ(cloud.points.dim(), 2);
      } catch (const std::runtime_error&) {
      }
    }
  }
}
