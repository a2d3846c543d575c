#pragma once
// PNG text metadata (the tEXt and uncompressed iTXt chunks), which OpenCV neither reads nor
// writes: a small chunk walker over the PNG byte stream (PNG spec, section 11.3.4).
#include <cstdint>
#include <map>
#include <string>

namespace omnipoint::data {

// keyword -> text for every tEXt chunk and uncompressed iTXt chunk (compressed ones are
// skipped). A stream that is not a well-formed PNG -> std::runtime_error naming `name`.
std::map<std::string, std::string> read_png_text(const std::string& png, const std::string& name);

// What a PNG's header (its first chunk, IHDR) says: the size, the bits per channel and the
// colour type (0 grey, 2 RGB, 3 palette, 4 grey + alpha, 6 RGBA). A stream that does not begin
// with the PNG signature and a whole IHDR -> std::runtime_error naming `name`.
struct PngHeader {
  std::int64_t width = 0, height = 0;
  int bit_depth = 0;
  int colour_type = 0;
};
PngHeader read_png_header(const std::string& png, const std::string& name);

// The CRC-32 that closes a PNG chunk, over its type and data.
std::uint32_t png_crc32(const std::string& type_and_data);

// The PNG with one tEXt chunk per entry inserted right after IHDR (Latin-1 text; keywords
// of 1-79 characters without NUL, else std::invalid_argument).
std::string add_png_text(const std::string& png, const std::map<std::string, std::string>& text);

}  // namespace omnipoint::data
