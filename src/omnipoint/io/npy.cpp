#include "omnipoint/io/npy.h"

#include <ATen/ATen.h>

#include <cctype>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "omnipoint/io/atomic_file.h"

namespace omnipoint::io {
namespace {

constexpr char kMagic[] = "\x93NUMPY";
constexpr std::size_t kMagicSize = 6;
constexpr std::size_t kMaxHeaderSize = 1 << 20;  // real headers are < 1 KiB

struct DtypeInfo {
  const char* descr;
  at::ScalarType type;
};
constexpr DtypeInfo kDtypes[] = {
    {"<f4", at::kFloat}, {"<f8", at::kDouble}, {"|u1", at::kByte},
    {"|b1", at::kBool},  {"<i4", at::kInt},    {"<i8", at::kLong},
};

[[noreturn]] void fail(const std::string& name, const std::string& what) {
  throw std::runtime_error(name + ": invalid .npy file: " + what);
}

// A strict reader of the Python dict literal that forms the .npy header, e.g.
// {'descr': '<f4', 'fortran_order': False, 'shape': (3, 4), }
class HeaderParser {
 public:
  HeaderParser(std::string text, std::string name) : s_(std::move(text)), name_(std::move(name)) {}

  std::string descr;
  bool fortran_order = false;
  std::vector<int64_t> shape;

  void parse() {
    bool has_descr = false, has_order = false, has_shape = false;
    expect('{');
    while (true) {
      skip_space();
      if (peek() == '}') {
        ++pos_;
        break;
      }
      const std::string key = string_literal();
      expect(':');
      if (key == "descr") {
        descr = string_literal();
        has_descr = true;
      } else if (key == "fortran_order") {
        fortran_order = boolean();
        has_order = true;
      } else if (key == "shape") {
        shape = tuple();
        has_shape = true;
      } else {
        fail(name_, "unexpected header key '" + key + "'");
      }
      skip_space();
      if (peek() == ',') {
        ++pos_;
        continue;
      }
      expect('}');
      break;
    }
    skip_space();
    if (pos_ != s_.size()) fail(name_, "trailing characters after the header dict");
    if (!has_descr || !has_order || !has_shape) {
      fail(name_, "header lacks one of 'descr', 'fortran_order', 'shape'");
    }
  }

 private:
  char peek() const { return pos_ < s_.size() ? s_[pos_] : '\0'; }
  void skip_space() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  void expect(char c) {
    skip_space();
    if (peek() != c) fail(name_, std::string("malformed header, expected '") + c + "'");
    ++pos_;
  }
  std::string string_literal() {
    skip_space();
    const char quote = peek();
    if (quote != '\'' && quote != '"') fail(name_, "malformed header, expected a string");
    const std::size_t end = s_.find(quote, pos_ + 1);
    if (end == std::string::npos) fail(name_, "malformed header, unterminated string");
    std::string out = s_.substr(pos_ + 1, end - pos_ - 1);
    pos_ = end + 1;
    return out;
  }
  bool boolean() {
    skip_space();
    if (s_.compare(pos_, 4, "True") == 0) {
      pos_ += 4;
      return true;
    }
    if (s_.compare(pos_, 5, "False") == 0) {
      pos_ += 5;
      return false;
    }
    fail(name_, "malformed header, expected True or False");
  }
  std::vector<int64_t> tuple() {
    std::vector<int64_t> dims;
    expect('(');
    while (true) {
      skip_space();
      if (peek() == ')') {
        ++pos_;
        break;
      }
      if (!std::isdigit(static_cast<unsigned char>(peek()))) fail(name_, "malformed shape");
      int64_t value = 0;
      while (std::isdigit(static_cast<unsigned char>(peek()))) {
        value = value * 10 + (s_[pos_++] - '0');
        if (value > (int64_t{1} << 40)) fail(name_, "shape dimension too large");
      }
      dims.push_back(value);
      skip_space();
      if (peek() == ',') {
        ++pos_;
        continue;
      }
      expect(')');
      break;
    }
    return dims;
  }

  std::string s_;
  std::string name_;
  std::size_t pos_ = 0;
};

uint32_t read_le(const unsigned char* p, int bytes) {
  uint32_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

}  // namespace

at::Tensor parse_npy(const char* data, std::size_t size, const std::string& name) {
  const auto* bytes = reinterpret_cast<const unsigned char*>(data);
  if (size < kMagicSize + 4 || std::memcmp(data, kMagic, kMagicSize) != 0) {
    fail(name, "missing the \\x93NUMPY magic");
  }
  const int major = bytes[6];
  std::size_t header_len = 0, header_start = 0;
  if (major == 1) {
    header_len = read_le(bytes + 8, 2);
    header_start = 10;
  } else if (major == 2 || major == 3) {
    if (size < 12) fail(name, "truncated header");
    header_len = read_le(bytes + 8, 4);
    header_start = 12;
  } else {
    fail(name, "unsupported format version " + std::to_string(major));
  }
  if (header_len > kMaxHeaderSize) fail(name, "header larger than 1 MiB");
  if (header_start + header_len > size) fail(name, "truncated header");

  HeaderParser header(std::string(data + header_start, header_len), name);
  header.parse();
  if (header.fortran_order) fail(name, "Fortran-order arrays are not supported (use C order)");

  at::ScalarType type = at::kFloat;
  bool known = false;
  for (const auto& d : kDtypes) {
    if (header.descr == d.descr) {
      type = d.type;
      known = true;
    }
  }
  if (!known) {
    fail(name,
         "unsupported dtype '" + header.descr + "' (expected <f4, <f8, |u1, |b1, <i4 or <i8)");
  }

  int64_t count = 1;
  for (int64_t d : header.shape) {
    if (d != 0 && count > std::numeric_limits<int64_t>::max() / d) fail(name, "shape overflows");
    count *= d;
  }
  const std::size_t payload = size - header_start - header_len;
  const auto item = static_cast<std::size_t>(c10::elementSize(type));
  if (static_cast<std::size_t>(count) > std::numeric_limits<std::size_t>::max() / item ||
      payload != static_cast<std::size_t>(count) * item) {
    std::ostringstream msg;
    msg << "data holds " << payload << " bytes but the header's shape and dtype need "
        << static_cast<std::size_t>(count) * item;
    fail(name, msg.str());
  }
  at::Tensor out = at::empty(header.shape, at::TensorOptions().dtype(type));
  if (payload > 0) std::memcpy(out.data_ptr(), data + header_start + header_len, payload);
  if (type == at::kBool) {
    // .npy booleans are bytes; anything but 0/1 is not a valid bool in memory.
    const auto* p = reinterpret_cast<const unsigned char*>(out.data_ptr());
    for (int64_t i = 0; i < count; ++i) {
      if (p[i] > 1) fail(name, "bool array holds a byte other than 0 or 1");
    }
  }
  return out;
}

at::Tensor read_npy(const std::string& path) {
  const std::string content = read_file(path);
  return parse_npy(content.data(), content.size(), path);
}

namespace {

// The magic, version and padded header of a contiguous CPU tensor's .npy file.
std::string npy_header(const at::Tensor& t) {
  const char* descr = nullptr;
  for (const auto& d : kDtypes) {
    if (t.scalar_type() == d.type) descr = d.descr;
  }
  if (descr == nullptr) {
    throw std::invalid_argument(std::string("cannot write dtype ") +
                                c10::toString(t.scalar_type()) + " to .npy");
  }
  std::ostringstream dict;
  dict << "{'descr': '" << descr << "', 'fortran_order': False, 'shape': (";
  for (int64_t i = 0; i < t.dim(); ++i)
    dict << t.size(i) << (t.dim() == 1 || i + 1 < t.dim() ? ", " : "");
  dict << "), }";
  std::string header = dict.str();
  // Pad with spaces so that data starts on a 64-byte boundary; the header ends in '\n'.
  const std::size_t unpadded = kMagicSize + 4 + header.size() + 1;
  header.append((64 - unpadded % 64) % 64, ' ');
  header.push_back('\n');

  std::string out(kMagic, kMagicSize);
  out.push_back('\x01');
  out.push_back('\x00');
  out.push_back(static_cast<char>(header.size() & 0xff));
  out.push_back(static_cast<char>((header.size() >> 8) & 0xff));
  return out + header;
}

}  // namespace

std::string encode_npy(const at::Tensor& tensor) {
  const at::Tensor t = tensor.detach().to(at::kCPU).contiguous();
  std::string out = npy_header(t);
  out.append(static_cast<const char*>(t.data_ptr()), t.numel() * t.element_size());
  return out;
}

void write_npy(const std::string& path, const at::Tensor& tensor) {
  // The data straight from the tensor: no copy of a file that can be hundreds of MB.
  const at::Tensor t = tensor.detach().to(at::kCPU).contiguous();
  const std::string header = npy_header(t);
  write_file_atomically(path, [&](std::ostream& out) {
    out.write(header.data(), static_cast<std::streamsize>(header.size()));
    out.write(static_cast<const char*>(t.data_ptr()),
              static_cast<std::streamsize>(t.numel() * t.element_size()));
  });
}

}  // namespace omnipoint::io
