// PCD point clouds in PCL's three encodings, written by the test (LZF through liblzf).
#include "omnipoint/io/pcd.h"

#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <lzf.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>
#include <vector>

#include "support/expect_error.h"

using omnipoint::io::parse_pcd;
using omnipoint::test::expect_error;

namespace {

// Three points with x y z float32, an rgb float, a 3-value "normal_like" histogram of doubles
// and a uint16 ring: the second point is PCL's NaN "no return" and is dropped.
const float kNan = std::numeric_limits<float>::quiet_NaN();
const std::vector<std::array<float, 3>> kPoints = {
    {1.5f, -2, 3}, {kNan, kNan, kNan}, {0, 0.25f, -8}};

std::string header(const std::string& data, size_t points = 3) {
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
         "FIELDS x y z rgb normal_like ring\nSIZE 4 4 4 4 8 2\nTYPE F F F F F U\n"
         "COUNT 1 1 1 1 3 1\nWIDTH " +
         std::to_string(points) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " +
         std::to_string(points) + "\nDATA " + data + "\n";
}

template <typename T>
void put(std::string& bytes, T value) {
  bytes.append(reinterpret_cast<const char*>(&value), sizeof(T));
}

// One point's fields in turn: x y z, rgb, 3 histogram values, ring.
void put_point(std::string& bytes, size_t i) {
  for (const float v : kPoints[i]) put<float>(bytes, v);
  put<float>(bytes, 4.2108e6f);
  for (int k = 0; k < 3; ++k) put<double>(bytes, 0.5 * k + i);
  put<uint16_t>(bytes, static_cast<uint16_t>(7 + i));
}

std::string ascii_pcd() {
  return header("ascii") +
         "1.5 -2 3 4.2108e+06 0 0.5 1 7\nnan nan nan 4.2108e+06 1 1.5 2 8\n"
         "0 0.25 -8 4.2108e+06 2 2.5 3 9\n";
}

std::string binary_pcd() {
  std::string bytes = header("binary");
  for (size_t i = 0; i < kPoints.size(); ++i) put_point(bytes, i);
  return bytes;
}

// binary_compressed: every field for all points in turn, LZF-compressed.
std::string field_major_data() {
  std::string records;
  for (size_t i = 0; i < kPoints.size(); ++i) put_point(records, i);
  const size_t record = 12 + 4 + 24 + 2;
  const size_t field_sizes[] = {4, 4, 4, 4, 24, 2};
  std::string fields;
  size_t offset = 0;
  for (const size_t size : field_sizes) {
    for (size_t i = 0; i < kPoints.size(); ++i) fields += records.substr(i * record + offset, size);
    offset += size;
  }
  return fields;
}

std::string compressed_pcd() {
  const std::string data = field_major_data();
  std::string compressed(data.size() * 2 + 16, '\0');
  const unsigned int size =
      lzf_compress(data.data(), data.size(), compressed.data(), compressed.size());
  EXPECT_GT(size, 0u);
  std::string bytes = header("binary_compressed");
  put<uint32_t>(bytes, size);
  put<uint32_t>(bytes, static_cast<uint32_t>(data.size()));
  return bytes + compressed.substr(0, size);
}

void expect_points(const at::Tensor& points) {
  const at::Tensor expected =
      at::tensor({1.5f, -2.0f, 3.0f, 0.0f, 0.25f, -8.0f}, at::kFloat).view({2, 3});
  EXPECT_EQ(points.scalar_type(), at::kFloat);
  ASSERT_EQ(points.sizes(), expected.sizes());
  EXPECT_TRUE(at::equal(points, expected)) << points;
}

TEST(Pcd, ReadsAllThreeEncodings) {
  expect_points(parse_pcd(ascii_pcd(), "a.pcd"));
  expect_points(parse_pcd(binary_pcd(), "b.pcd"));
  expect_points(parse_pcd(compressed_pcd(), "c.pcd"));
}

TEST(Pcd, ReadsIntegerAndDoubleCoordinatesWithoutCountOrViewpoint) {
  std::string bytes =
      "VERSION .7\nFIELDS intensity x y z\nSIZE 1 8 2 4\nTYPE U F I U\nWIDTH 2\nHEIGHT 1\n"
      "DATA binary\n";
  put<uint8_t>(bytes, 9), put<double>(bytes, -0.5), put<int16_t>(bytes, -3),
      put<uint32_t>(bytes, 70000);
  put<uint8_t>(bytes, 1), put<double>(bytes, 2), put<int16_t>(bytes, 4), put<uint32_t>(bytes, 5);
  const at::Tensor points = parse_pcd(bytes, "ints.pcd");
  EXPECT_TRUE(
      at::equal(points, at::tensor({-0.5f, -3.0f, 70000.0f, 2.0f, 4.0f, 5.0f}).view({2, 3})))
      << points;
}

TEST(Pcd, EmptyCloudHasNoPoints) {
  EXPECT_EQ(parse_pcd(header("binary", 0), "e.pcd").sizes(), (at::IntArrayRef{0, 3}));
}

TEST(Pcd, BadHeadersAreErrors) {
  expect_error<std::invalid_argument>([] { parse_pcd("just text\n", "t.pcd"); },
                                      {"PCD file t.pcd", "unknown header line 'just'"});
  expect_error<std::invalid_argument>([] { parse_pcd("VERSION .7\nFIELDS x y z\n", "n.pcd"); },
                                      {"n.pcd", "no DATA line"});
  std::string no_z = ascii_pcd();
  no_z.replace(no_z.find("FIELDS x y z"), 12, "FIELDS x y w");
  expect_error<std::invalid_argument>([&] { parse_pcd(no_z, "z.pcd"); }, {"z.pcd", "no field z"});
  std::string size_type = binary_pcd();
  size_type.replace(size_type.find("SIZE 4 4 4"), 10, "SIZE 4 4 2");
  expect_error<std::invalid_argument>([&] { parse_pcd(size_type, "s.pcd"); },
                                      {"s.pcd", "field z has TYPE F SIZE 2"});
  std::string viewpoint = ascii_pcd();
  viewpoint.replace(viewpoint.find("VIEWPOINT 0 0 0"), 15, "VIEWPOINT 1 0 0");
  expect_error<std::invalid_argument>([&] { parse_pcd(viewpoint, "v.pcd"); },
                                      {"v.pcd", "VIEWPOINT is not the identity"});
  std::string points = ascii_pcd();
  points.replace(points.find("POINTS 3"), 8, "POINTS 4");
  expect_error<std::invalid_argument>([&] { parse_pcd(points, "p.pcd"); },
                                      {"p.pcd", "POINTS is not WIDTH * HEIGHT = 3"});
  std::string encoding = ascii_pcd();
  encoding.replace(encoding.find("DATA ascii"), 10, "DATA binary_scaled");
  expect_error<std::invalid_argument>([&] { parse_pcd(encoding, "d.pcd"); },
                                      {"d.pcd", "DATA 'binary_scaled'"});
}

TEST(Pcd, TruncatedDataIsAnError) {
  const std::string binary = binary_pcd();
  expect_error<std::invalid_argument>(
      [&] { parse_pcd(binary.substr(0, binary.size() - 1), "b.pcd"); },
      {"b.pcd", "3 POINTS of 42 bytes do not fit in the file (125 bytes)"});
  const std::string ascii = ascii_pcd();
  expect_error<std::invalid_argument>(
      [&] { parse_pcd(ascii.substr(0, ascii.rfind("0 0.25")), "a.pcd"); },
      {"a.pcd", "truncated: 2 data lines for 3 POINTS"});
  expect_error<std::invalid_argument>(
      [&] { parse_pcd(header("ascii") + "1 2 3 4 5 6 7\n", "a.pcd"); },
      {"a.pcd", "data line 1 has 7 values (expected 8)"});
  const std::string compressed = compressed_pcd();
  expect_error<std::invalid_argument>(
      [&] { parse_pcd(compressed.substr(0, compressed.size() - 2), "c.pcd"); },
      {"c.pcd", "compressed size", "bytes follow"});
}

TEST(Pcd, WrongCompressedSizesAreErrors) {
  const std::string good = compressed_pcd();
  const size_t sizes = header("binary_compressed").size();
  std::string uncompressed = good;
  const uint32_t wrong = 100;
  std::memcpy(uncompressed.data() + sizes + 4, &wrong, 4);
  expect_error<std::invalid_argument>([&] { parse_pcd(uncompressed, "u.pcd"); },
                                      {"u.pcd", "uncompressed size 100 (the 3 POINTS need 126)"});
  std::string corrupt = good;
  corrupt[sizes + 8] = static_cast<char>(0xff);  // a back reference before the start
  expect_error<std::invalid_argument>([&] { parse_pcd(corrupt, "x.pcd"); },
                                      {"x.pcd", "the LZF data does not decompress to 126 bytes"});
  std::string huge = header("binary_compressed", 1u << 30);
  put<uint32_t>(huge, 4), put<uint32_t>(huge, 0xffffffffu), put<uint32_t>(huge, 0);
  expect_error<std::invalid_argument>([&] { parse_pcd(huge, "h.pcd"); },
                                      {"h.pcd", "do not fit in LZF data"});
}

}  // namespace
