#include "omnipoint/io/ply.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cctype>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "omnipoint/io/atomic_file.h"

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "PLY and npy I/O copy little-endian bytes directly");

namespace omnipoint::io {
namespace {

constexpr std::size_t kMaxHeaderBytes = 1 << 16;

enum class Scalar { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

struct Property {
  std::string name;
  Scalar type;
  std::size_t offset;  // byte offset inside a binary record
};

std::size_t scalar_size(Scalar t) {
  switch (t) {
    case Scalar::Int8:
    case Scalar::UInt8:
      return 1;
    case Scalar::Int16:
    case Scalar::UInt16:
      return 2;
    case Scalar::Int32:
    case Scalar::UInt32:
    case Scalar::Float32:
      return 4;
    case Scalar::Float64:
      return 8;
  }
  return 0;
}

bool parse_scalar_type(const std::string& s, Scalar& type) {
  static const std::pair<const char*, Scalar> names[] = {
      {"char", Scalar::Int8},      {"int8", Scalar::Int8},       {"uchar", Scalar::UInt8},
      {"uint8", Scalar::UInt8},    {"short", Scalar::Int16},     {"int16", Scalar::Int16},
      {"ushort", Scalar::UInt16},  {"uint16", Scalar::UInt16},   {"int", Scalar::Int32},
      {"int32", Scalar::Int32},    {"uint", Scalar::UInt32},     {"uint32", Scalar::UInt32},
      {"float", Scalar::Float32},  {"float32", Scalar::Float32}, {"double", Scalar::Float64},
      {"float64", Scalar::Float64}};
  for (const auto& [n, t] : names) {
    if (s == n) {
      type = t;
      return true;
    }
  }
  return false;
}

double load_binary(const char* p, Scalar t) {
  const auto get = [p](auto v) {
    std::memcpy(&v, p, sizeof(v));
    return static_cast<double>(v);
  };
  switch (t) {
    case Scalar::Int8:
      return get(std::int8_t{});
    case Scalar::UInt8:
      return get(std::uint8_t{});
    case Scalar::Int16:
      return get(std::int16_t{});
    case Scalar::UInt16:
      return get(std::uint16_t{});
    case Scalar::Int32:
      return get(std::int32_t{});
    case Scalar::UInt32:
      return get(std::uint32_t{});
    case Scalar::Float32:
      return get(float{});
    case Scalar::Float64:
      return get(double{});
  }
  return 0;
}

struct Header {
  bool binary = false;
  std::int64_t count = 0;
  std::vector<Property> properties;
  std::size_t record_size = 0;
  std::size_t data_offset = 0;
};

Header parse_header(const std::string& bytes, const std::string& name) {
  const auto fail = [&](const std::string& what) -> Header {
    throw std::runtime_error(name + ": not a supported PLY point cloud: " + what);
  };
  Header h;
  std::size_t pos = 0;
  int line_number = 0;
  bool have_format = false, in_vertex = false, seen_element = false;
  while (true) {
    const std::size_t end = bytes.find('\n', pos);
    if (end > kMaxHeaderBytes)  // npos (no newline at all) included
      fail("no end_header line in the first 64 KiB");
    std::string line = bytes.substr(pos, end - pos);
    if (!line.empty() && line.back() == '\r') line.pop_back();
    pos = end + 1;
    ++line_number;
    std::istringstream words(line);
    std::string keyword;
    words >> keyword;
    if (line_number == 1) {
      if (line != "ply") fail("the file does not start with 'ply'");
      continue;
    }
    if (keyword == "end_header") break;
    if (keyword == "comment" || keyword == "obj_info" || keyword.empty()) continue;
    if (keyword == "format") {
      std::string format, version;
      words >> format >> version;
      if (version != "1.0") fail("format version '" + version + "' (expected 1.0)");
      if (format == "ascii")
        h.binary = false;
      else if (format == "binary_little_endian")
        h.binary = true;
      else
        fail("format '" + format + "' (expected ascii or binary_little_endian)");
      have_format = true;
    } else if (keyword == "element") {
      std::string element, count;
      words >> element >> count;
      if (!seen_element) {
        if (element != "vertex") fail("the first element is '" + element + "' (expected vertex)");
        if (count.empty() || count.size() > 12 ||
            count.find_first_not_of("0123456789") != std::string::npos) {
          fail("bad vertex count '" + count + "'");
        }
        h.count = std::stoll(count);
      }
      in_vertex = !seen_element;
      seen_element = true;
    } else if (keyword == "property") {
      if (!seen_element) fail("a property before any element");
      if (!in_vertex) continue;
      std::string type, prop;
      words >> type >> prop;
      if (type == "list") fail("list property in the vertex element");
      Scalar scalar;
      if (!parse_scalar_type(type, scalar)) fail("unknown property type '" + type + "'");
      if (prop.empty()) fail("a property without a name");
      h.properties.push_back({prop, scalar, h.record_size});
      h.record_size += scalar_size(scalar);
    } else {
      fail("unknown header line '" + line + "'");
    }
  }
  if (!have_format) fail("no format line");
  if (!seen_element) fail("no vertex element");
  h.data_offset = pos;
  return h;
}

int find_property(const Header& h, const char* name) {
  for (std::size_t i = 0; i < h.properties.size(); ++i) {
    if (h.properties[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

}  // namespace

void write_ply(const std::string& path, const at::Tensor& points, const at::Tensor& colors) {
  if (!points.defined() || points.dim() != 2 || points.size(1) != 3 ||
      !at::isFloatingType(points.scalar_type())) {
    throw std::invalid_argument(path + ": PLY points must be a floating tensor of shape (N, 3)");
  }
  if (colors.defined() && (colors.scalar_type() != at::kByte || colors.sizes() != points.sizes())) {
    throw std::invalid_argument(path + ": PLY colours must be a uint8 tensor of shape (N, 3)");
  }
  const at::Tensor xyz = points.to(at::kCPU, at::kFloat).contiguous();
  if (!at::isfinite(xyz).all().item<bool>()) {
    throw std::invalid_argument(path + ": PLY points must be finite (keep only the valid points)");
  }
  const at::Tensor rgb = colors.defined() ? colors.to(at::kCPU).contiguous() : at::Tensor();
  const std::int64_t n = xyz.size(0);
  std::ostringstream header;
  header << "ply\nformat binary_little_endian 1.0\ncomment written by OmniPoint\n"
         << "element vertex " << n << "\nproperty float x\nproperty float y\nproperty float z\n";
  if (rgb.defined()) header << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  header << "end_header\n";
  const std::size_t record = 12 + (rgb.defined() ? 3 : 0);
  const float* p = xyz.data_ptr<float>();
  const std::uint8_t* c = rgb.defined() ? rgb.data_ptr<std::uint8_t>() : nullptr;
  const std::string head = header.str();
  write_file_atomically(path, [&](std::ostream& out) {
    out.write(head.data(), static_cast<std::streamsize>(head.size()));
    // Interleaved through one reused block: a copy of the whole cloud would be as big as the file.
    constexpr std::int64_t kBlock = 65536;
    std::string block(static_cast<std::size_t>(kBlock) * record, '\0');
    for (std::int64_t first = 0; first < n; first += kBlock) {
      const std::int64_t count = std::min(kBlock, n - first);
      for (std::int64_t i = 0; i < count; ++i) {
        std::memcpy(&block[i * record], p + 3 * (first + i), 12);
        if (c) std::memcpy(&block[i * record + 12], c + 3 * (first + i), 3);
      }
      out.write(block.data(), static_cast<std::streamsize>(count * record));
    }
  });
}

PlyPoints parse_ply(const std::string& bytes, const std::string& name) {
  const Header h = parse_header(bytes, name);
  const int ix = find_property(h, "x"), iy = find_property(h, "y"), iz = find_property(h, "z");
  if (ix < 0 || iy < 0 || iz < 0) {
    throw std::runtime_error(name + ": PLY vertex element lacks one of the properties x, y, z");
  }
  const int ir = find_property(h, "red"), ig = find_property(h, "green"),
            ib = find_property(h, "blue");
  const bool has_color = ir >= 0 || ig >= 0 || ib >= 0;
  if (has_color &&
      (ir < 0 || ig < 0 || ib < 0 || h.properties[ir].type != Scalar::UInt8 ||
       h.properties[ig].type != Scalar::UInt8 || h.properties[ib].type != Scalar::UInt8)) {
    throw std::runtime_error(name +
                             ": PLY colours must be the three uchar properties red, green, blue");
  }
  const std::size_t available = bytes.size() - h.data_offset;
  const std::size_t num_props = h.properties.size();
  // Every value takes at least one byte in either encoding: reject impossible counts early.
  const std::size_t min_bytes = h.binary ? h.record_size : 2 * num_props;
  if (min_bytes == 0 || static_cast<std::size_t>(h.count) > available / min_bytes) {
    throw std::runtime_error(name + ": PLY file is truncated: " + std::to_string(h.count) +
                             " vertices declared, the data is shorter");
  }
  at::Tensor points = at::empty({h.count, 3}, at::kFloat);
  at::Tensor colors = has_color ? at::empty({h.count, 3}, at::kByte) : at::Tensor();
  float* out = points.data_ptr<float>();
  std::uint8_t* rgb = has_color ? colors.data_ptr<std::uint8_t>() : nullptr;
  std::vector<double> values(num_props);
  const char* cursor = bytes.data() + h.data_offset;
  const char* const end = bytes.data() + bytes.size();
  for (std::int64_t i = 0; i < h.count; ++i) {
    if (h.binary) {
      for (std::size_t k = 0; k < num_props; ++k) {
        values[k] = load_binary(cursor + h.properties[k].offset, h.properties[k].type);
      }
      cursor += h.record_size;
    } else {
      for (std::size_t k = 0; k < num_props; ++k) {
        while (cursor < end && std::isspace(static_cast<unsigned char>(*cursor))) ++cursor;
        const char* token = cursor;
        while (cursor < end && !std::isspace(static_cast<unsigned char>(*cursor))) ++cursor;
        const std::string text(token, cursor);
        char* parsed_end = nullptr;
        values[k] = text.empty() ? 0.0 : std::strtod(text.c_str(), &parsed_end);
        if (text.empty() || parsed_end != text.c_str() + text.size()) {
          throw std::runtime_error(name + ": PLY vertex " + std::to_string(i) +
                                   " has a bad or missing value '" + text + "'");
        }
      }
    }
    out[3 * i] = static_cast<float>(values[ix]);
    out[3 * i + 1] = static_cast<float>(values[iy]);
    out[3 * i + 2] = static_cast<float>(values[iz]);
    if (rgb) {
      for (int c = 0; c < 3; ++c) {
        const double v = values[c == 0 ? ir : c == 1 ? ig : ib];
        if (!(v >= 0 && v <= 255)) {
          throw std::runtime_error(name + ": PLY vertex " + std::to_string(i) +
                                   " has a colour outside 0..255");
        }
        rgb[3 * i + c] = static_cast<std::uint8_t>(v);
      }
    }
  }
  return {points, colors};
}

PlyPoints read_ply(const std::string& path) {
  return parse_ply(read_file(path), path);
}

}  // namespace omnipoint::io
