#include "omnipoint/data/png_text.h"

#include <array>
#include <cstdint>
#include <stdexcept>

namespace omnipoint::data {
namespace {

constexpr char kSignature[] = "\x89PNG\r\n\x1a\n";
constexpr std::size_t kSignatureSize = 8;

}  // namespace

std::uint32_t png_crc32(const std::string& bytes) {
  static const auto table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xFFFFFFFFu;
  for (unsigned char b : bytes) c = table[(c ^ b) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

namespace {

std::uint32_t read_u32(const std::string& s, std::size_t at) {
  return (std::uint32_t(static_cast<unsigned char>(s[at])) << 24) |
         (std::uint32_t(static_cast<unsigned char>(s[at + 1])) << 16) |
         (std::uint32_t(static_cast<unsigned char>(s[at + 2])) << 8) |
         std::uint32_t(static_cast<unsigned char>(s[at + 3]));
}

std::string u32(std::uint32_t v) {
  return {char(v >> 24), char((v >> 16) & 0xFF), char((v >> 8) & 0xFF), char(v & 0xFF)};
}

struct Chunk {
  std::string type;
  std::size_t data_at, length;
};

// Walks the chunk list, checking lengths and CRCs.
template <typename Visit>
void walk(const std::string& png, const std::string& name, Visit visit) {
  const auto fail = [&](const std::string& why) {
    throw std::runtime_error(name + ": not a valid PNG (" + why + ")");
  };
  if (png.size() < kSignatureSize ||
      png.compare(0, kSignatureSize, kSignature, kSignatureSize) != 0)
    fail("bad signature");
  std::size_t at = kSignatureSize;
  bool ended = false;
  while (!ended) {
    if (at + 12 > png.size()) fail("truncated chunk");
    const std::size_t length = read_u32(png, at);
    if (length > png.size() - at - 12) fail("chunk longer than the file");
    const std::string type = png.substr(at + 4, 4);
    if (png_crc32(png.substr(at + 4, 4 + length)) != read_u32(png, at + 8 + length))
      fail("CRC mismatch in " + type);
    visit(Chunk{type, at + 8, length});
    ended = type == "IEND";
    at += 12 + length;
  }
}

}  // namespace

PngHeader read_png_header(const std::string& png, const std::string& name) {
  // Signature (8 bytes), then IHDR: length 13, "IHDR", width, height, bit depth, colour type.
  if (png.size() < kSignatureSize + 8 + 13 ||
      png.compare(0, kSignatureSize, kSignature, kSignatureSize) != 0 ||
      read_u32(png, kSignatureSize) != 13 || png.compare(kSignatureSize + 4, 4, "IHDR") != 0)
    throw std::runtime_error(name + ": not a PNG file (no PNG signature and header)");
  PngHeader header;
  header.width = read_u32(png, kSignatureSize + 8);
  header.height = read_u32(png, kSignatureSize + 12);
  header.bit_depth = static_cast<unsigned char>(png[kSignatureSize + 16]);
  header.colour_type = static_cast<unsigned char>(png[kSignatureSize + 17]);
  return header;
}

std::map<std::string, std::string> read_png_text(const std::string& png, const std::string& name) {
  std::map<std::string, std::string> text;
  walk(png, name, [&](const Chunk& c) {
    const std::string data = png.substr(c.data_at, c.length);
    const auto nul = data.find('\0');
    if (nul == std::string::npos) return;
    const std::string keyword = data.substr(0, nul);
    if (c.type == "tEXt") {
      text[keyword] = data.substr(nul + 1);
    } else if (c.type == "iTXt" && nul + 2 < data.size() && data[nul + 1] == 0) {
      // keyword \0 flag method language \0 translated keyword \0 text
      const auto language_end = data.find('\0', nul + 3);
      if (language_end == std::string::npos) return;
      const auto translated_end = data.find('\0', language_end + 1);
      if (translated_end == std::string::npos) return;
      text[keyword] = data.substr(translated_end + 1);
    }
  });
  return text;
}

std::string add_png_text(const std::string& png, const std::map<std::string, std::string>& text) {
  std::size_t after_header = 0;
  walk(png, "png", [&](const Chunk& c) {
    if (c.type == "IHDR") after_header = c.data_at + c.length + 4;
  });
  if (after_header == 0) throw std::runtime_error("png: no IHDR chunk");
  std::string chunks;
  for (const auto& [keyword, value] : text) {
    if (keyword.empty() || keyword.size() > 79 || keyword.find('\0') != std::string::npos)
      throw std::invalid_argument("PNG text keyword '" + keyword + "': expected 1-79 characters");
    const std::string body = "tEXt" + keyword + std::string(1, '\0') + value;
    chunks += u32(static_cast<std::uint32_t>(body.size() - 4)) + body + u32(png_crc32(body));
  }
  return png.substr(0, after_header) + chunks + png.substr(after_header);
}

}  // namespace omnipoint::data
