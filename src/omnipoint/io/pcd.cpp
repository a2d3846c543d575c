#include "omnipoint/io/pcd.h"

#include <ATen/ATen.h>
#include <lzf.h>

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "omnipoint/io/atomic_file.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "PCD binary data is read by copying little-endian bytes");

namespace omnipoint::io {
namespace {

constexpr size_t kMaxHeaderBytes = 1 << 16;
// Caps on values read from the header, far above real clouds, so that sizes computed from
// them cannot overflow.
constexpr uint64_t kMaxFieldCount = 1 << 20;
constexpr uint64_t kMaxImageSide = uint64_t{1} << 31;
// LZF turns 3 bytes into at most 264, so a larger ratio is a corrupt header (and would be a
// huge allocation).
constexpr uint64_t kMaxLzfExpansion = 90;

enum class Encoding { Ascii, Binary, BinaryCompressed };

struct Field {
  std::string name;
  char type = 'F';  // F float, I signed, U unsigned
  uint64_t size = 4;
  uint64_t count = 1;
  uint64_t offset = 0;  // bytes of the fields before it, per point
};

struct Header {
  std::vector<Field> fields;
  uint64_t points = 0;
  uint64_t point_size = 0;  // bytes of all fields of one point
  Encoding encoding = Encoding::Ascii;
  size_t data_offset = 0;
};

[[noreturn]] void fail(const std::string& name, const std::string& what) {
  throw std::invalid_argument("PCD file " + name + ": " + what);
}

std::vector<std::string> words_of(const std::string& line) {
  std::istringstream stream(line);
  std::vector<std::string> words;
  for (std::string word; stream >> word;) words.push_back(word);
  return words;
}

template <typename T>
bool parse_whole(const std::string& token, T& value) {
  const char* end = token.data() + token.size();
  const auto [stop, error] = std::from_chars(token.data(), end, value);
  return error == std::errc() && stop == end;
}

uint64_t header_integer(const std::string& token, const std::string& key, uint64_t max,
                        const std::string& name) {
  uint64_t value = 0;
  if (!parse_whole(token, value) || value > max)
    fail(name, key + " '" + token + "' is not an integer 0.." + std::to_string(max));
  return value;
}

bool valid_size(char type, uint64_t size) {
  if (type == 'F') return size == 4 || size == 8;
  return (type == 'I' || type == 'U') && (size == 1 || size == 2 || size == 4 || size == 8);
}

// The header's lines up to DATA, keyed by their first word.
std::map<std::string, std::vector<std::string>> header_lines(const std::string& bytes,
                                                             const std::string& name,
                                                             size_t& data_offset) {
  std::map<std::string, std::vector<std::string>> lines;
  size_t pos = 0;
  while (true) {
    const size_t end = bytes.find('\n', pos);
    if (end > kMaxHeaderBytes)  // npos (no newline at all) included
      fail(name, "no DATA line in the first 64 KiB (not a PCD file?)");
    std::vector<std::string> words = words_of(bytes.substr(pos, end - pos));
    pos = end + 1;
    if (words.empty() || words[0][0] == '#') continue;
    static const char* const kKeys[] = {"VERSION", "FIELDS", "SIZE",      "TYPE",   "COUNT",
                                        "WIDTH",   "HEIGHT", "VIEWPOINT", "POINTS", "DATA"};
    const std::string key = words[0];
    if (std::find(std::begin(kKeys), std::end(kKeys), key) == std::end(kKeys))
      fail(name, "unknown header line '" + key + "'");
    if (lines.count(key)) fail(name, "the header line " + key + " appears twice");
    words.erase(words.begin());
    lines[key] = words;
    if (key == "DATA") break;
  }
  data_offset = pos;
  return lines;
}

Header parse_header(const std::string& bytes, const std::string& name) {
  Header header;
  auto lines = header_lines(bytes, name, header.data_offset);
  for (const char* key : {"FIELDS", "SIZE", "TYPE", "WIDTH", "HEIGHT"})
    if (!lines.count(key)) fail(name, std::string("the header has no ") + key + " line");
  const std::vector<std::string>& names = lines["FIELDS"];
  if (!lines.count("COUNT")) lines["COUNT"] = std::vector<std::string>(names.size(), "1");
  for (const char* key : {"SIZE", "TYPE", "COUNT"})
    if (lines[key].size() != names.size())
      fail(name, std::string(key) + " lists " + std::to_string(lines[key].size()) + " values for " +
                     std::to_string(names.size()) + " FIELDS");
  for (size_t i = 0; i < names.size(); ++i) {
    Field field;
    field.name = names[i];
    const std::string& type = lines["TYPE"][i];
    field.type = type.size() == 1 ? type[0] : '?';
    field.size = header_integer(lines["SIZE"][i], "SIZE", 8, name);
    field.count = header_integer(lines["COUNT"][i], "COUNT", kMaxFieldCount, name);
    if (!valid_size(field.type, field.size))
      fail(name, "field " + field.name + " has TYPE " + type + " SIZE " + lines["SIZE"][i] +
                     " (expected F 4/8, I or U 1/2/4/8)");
    field.offset = header.point_size;
    header.point_size += field.size * field.count;
    header.fields.push_back(field);
  }
  const uint64_t width =
      header_integer(lines["WIDTH"].empty() ? "" : lines["WIDTH"][0], "WIDTH", kMaxImageSide, name);
  const uint64_t height = header_integer(lines["HEIGHT"].empty() ? "" : lines["HEIGHT"][0],
                                         "HEIGHT", kMaxImageSide, name);
  header.points = width * height;
  if (lines.count("POINTS") &&
      header_integer(lines["POINTS"].empty() ? "" : lines["POINTS"][0], "POINTS",
                     std::numeric_limits<uint64_t>::max(), name) != header.points)
    fail(name, "POINTS is not WIDTH * HEIGHT = " + std::to_string(header.points));
  if (lines.count("VIEWPOINT")) {
    const std::vector<std::string>& pose = lines["VIEWPOINT"];
    std::vector<double> values(pose.size());
    for (size_t i = 0; i < pose.size(); ++i)
      if (!parse_whole(pose[i], values[i])) fail(name, "VIEWPOINT has a bad number " + pose[i]);
    const std::vector<double> identity = {0, 0, 0, 1, 0, 0, 0};
    if (values != identity)
      fail(name,
           "VIEWPOINT is not the identity 0 0 0 1 0 0 0 (transform the cloud into the sensor "
           "frame first, e.g. with pcl_transform_point_cloud)");
  }
  const std::vector<std::string>& data = lines["DATA"];
  const std::string encoding = data.empty() ? "" : data[0];
  if (encoding == "ascii")
    header.encoding = Encoding::Ascii;
  else if (encoding == "binary")
    header.encoding = Encoding::Binary;
  else if (encoding == "binary_compressed")
    header.encoding = Encoding::BinaryCompressed;
  else
    fail(name, "DATA '" + encoding + "' (expected ascii, binary or binary_compressed)");
  return header;
}

// The index of the field named `axis`, which must be a single number.
size_t coordinate_field(const Header& header, const std::string& axis, const std::string& name) {
  size_t found = header.fields.size();
  for (size_t i = 0; i < header.fields.size(); ++i) {
    if (header.fields[i].name != axis) continue;
    if (found != header.fields.size()) fail(name, "the field " + axis + " appears twice");
    found = i;
  }
  if (found == header.fields.size()) fail(name, "no field " + axis + " (FIELDS must hold x y z)");
  if (header.fields[found].count != 1)
    fail(name, "the field " + axis + " has COUNT " + std::to_string(header.fields[found].count) +
                   " (expected 1)");
  return found;
}

double load_value(const char* p, const Field& field) {
  const auto get = [p](auto value) {
    std::memcpy(&value, p, sizeof(value));
    return static_cast<double>(value);
  };
  if (field.type == 'F') return field.size == 4 ? get(float{}) : get(double{});
  const bool is_signed = field.type == 'I';
  switch (field.size) {
    case 1:
      return is_signed ? get(int8_t{}) : get(uint8_t{});
    case 2:
      return is_signed ? get(int16_t{}) : get(uint16_t{});
    case 4:
      return is_signed ? get(int32_t{}) : get(uint32_t{});
    default:
      return is_signed ? get(int64_t{}) : get(uint64_t{});
  }
}

// x, y, z of each point from ascii lines (one point per line, every field's values in turn).
std::vector<double> ascii_points(const std::string& text, const Header& header,
                                 const size_t axes[3], const std::string& name) {
  std::vector<size_t> first_value;  // of each field, in a line's values
  size_t values_per_point = 0;
  for (const Field& field : header.fields) {
    first_value.push_back(values_per_point);
    values_per_point += field.count;
  }
  std::vector<double> xyz;
  std::istringstream lines(text);
  uint64_t point = 0;
  for (std::string line; std::getline(lines, line);) {
    const std::vector<std::string> values = words_of(line);
    if (values.empty()) continue;
    if (point == header.points)
      fail(name, "more data lines than the " + std::to_string(header.points) + " POINTS");
    if (values.size() != values_per_point)
      fail(name, "data line " + std::to_string(point + 1) + " has " +
                     std::to_string(values.size()) + " values (expected " +
                     std::to_string(values_per_point) + ")");
    for (const std::string& value : values) {
      double number = 0;
      if (!parse_whole(value, number))
        fail(name, "data line " + std::to_string(point + 1) + " has a bad value '" + value + "'");
    }
    for (int axis = 0; axis < 3; ++axis) {
      double number = 0;
      parse_whole(values[first_value[axes[axis]]], number);
      xyz.push_back(number);
    }
    ++point;
  }
  if (point != header.points)
    fail(name, "truncated: " + std::to_string(point) + " data lines for " +
                   std::to_string(header.points) + " POINTS");
  return xyz;
}

// x, y, z of each point from binary data: records (`field_major` false) or, as
// binary_compressed holds them after decompression, each field for all points in turn.
std::vector<double> binary_points(const char* data, const Header& header, const size_t axes[3],
                                  bool field_major) {
  std::vector<double> xyz;
  xyz.reserve(3 * header.points);
  for (uint64_t point = 0; point < header.points; ++point) {
    for (int axis = 0; axis < 3; ++axis) {
      const Field& field = header.fields[axes[axis]];
      const uint64_t at = field_major ? header.points * field.offset + point * field.size
                                      : point * header.point_size + field.offset;
      xyz.push_back(load_value(data + at, field));
    }
  }
  return xyz;
}

// The expected data size, checked against what the file can hold.
uint64_t data_size(const Header& header, uint64_t available, const std::string& what,
                   const std::string& name) {
  if (header.points > available / header.point_size)
    fail(name, std::to_string(header.points) + " POINTS of " + std::to_string(header.point_size) +
                   " bytes do not fit in " + what + " (" + std::to_string(available) + " bytes)");
  return header.points * header.point_size;
}

std::string decompressed(const std::string& bytes, const Header& header, const std::string& name) {
  const size_t begin = header.data_offset;
  if (bytes.size() - begin < 8) fail(name, "binary_compressed data shorter than its 8-byte sizes");
  uint32_t compressed_size = 0, uncompressed_size = 0;
  std::memcpy(&compressed_size, bytes.data() + begin, 4);
  std::memcpy(&uncompressed_size, bytes.data() + begin + 4, 4);
  const uint64_t following = bytes.size() - begin - 8;
  if (compressed_size != following)
    fail(name, "compressed size " + std::to_string(compressed_size) + " but " +
                   std::to_string(following) + " bytes follow");
  const uint64_t expected =
      data_size(header, uint64_t{compressed_size} * kMaxLzfExpansion, "LZF data", name);
  if (uncompressed_size != expected)
    fail(name, "uncompressed size " + std::to_string(uncompressed_size) + " (the " +
                   std::to_string(header.points) + " POINTS need " + std::to_string(expected) +
                   ")");
  std::string data(uncompressed_size, '\0');
  if (uncompressed_size > 0 && lzf_decompress(bytes.data() + begin + 8, compressed_size,
                                              data.data(), uncompressed_size) != uncompressed_size)
    fail(name,
         "the LZF data does not decompress to " + std::to_string(uncompressed_size) + " bytes");
  return data;
}

}  // namespace

at::Tensor parse_pcd(const std::string& bytes, const std::string& name) {
  const Header header = parse_header(bytes, name);
  const size_t axes[3] = {coordinate_field(header, "x", name), coordinate_field(header, "y", name),
                          coordinate_field(header, "z", name)};
  std::vector<double> xyz;
  if (header.encoding == Encoding::Ascii) {
    xyz = ascii_points(bytes.substr(header.data_offset), header, axes, name);
  } else if (header.encoding == Encoding::Binary) {
    const uint64_t available = bytes.size() - header.data_offset;
    if (data_size(header, available, "the file", name) != available)
      fail(name, "binary data of " + std::to_string(available) + " bytes for " +
                     std::to_string(header.points) + " POINTS of " +
                     std::to_string(header.point_size) + " bytes");
    xyz = binary_points(bytes.data() + header.data_offset, header, axes, false);
  } else {
    const std::string data = decompressed(bytes, header, name);
    xyz = binary_points(data.data(), header, axes, true);
  }
  std::vector<float> kept;  // points with finite coordinates
  kept.reserve(xyz.size());
  for (size_t i = 0; i < xyz.size(); i += 3) {
    const float point[3] = {static_cast<float>(xyz[i]), static_cast<float>(xyz[i + 1]),
                            static_cast<float>(xyz[i + 2])};
    if (std::isfinite(point[0]) && std::isfinite(point[1]) && std::isfinite(point[2]))
      kept.insert(kept.end(), point, point + 3);
  }
  return at::tensor(kept, at::kFloat).view({-1, 3});
}

at::Tensor read_pcd(const std::string& path) {
  return parse_pcd(read_file(path), path);
}

}  // namespace omnipoint::io
