#pragma once
// JPEG files with EXIF data that the tests compose byte by byte (the TIFF structure of the EXIF
// standard, CIPA DC-008, in either byte order), so that the reader under test (libexif) meets
// bytes it did not write itself.
#include <algorithm>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace omnipoint::test {

struct ExifTags {
  std::optional<int> orientation;                                       // 0x0112, SHORT
  std::string make;                                                     // 0x010F, ASCII; "": none
  std::optional<int> focal_length_35mm;                                 // 0xA405, SHORT
  std::optional<std::pair<std::uint32_t, std::uint32_t>> focal_length;  // 0x920A, RATIONAL
  std::optional<std::pair<std::uint32_t, std::uint32_t>> focal_plane_x_resolution;  // 0xA20E
  std::optional<int> focal_plane_resolution_unit;                                   // 0xA210, SHORT
  std::optional<std::uint32_t> pixel_x_dimension;                                   // 0xA002, LONG
  bool big_endian = false;  // "MM" rather than "II"
};

namespace exif_detail {

struct Entry {
  std::uint16_t tag, type;
  std::uint32_t count;
  std::string value;  // in the file's byte order
};

inline std::string number(std::uint64_t value, int bytes, bool big_endian) {
  std::string out(static_cast<std::size_t>(bytes), '\0');
  for (int i = 0; i < bytes; ++i) {
    const int shift = 8 * (big_endian ? bytes - 1 - i : i);
    out[static_cast<std::size_t>(i)] = static_cast<char>((value >> shift) & 0xff);
  }
  return out;
}

// An IFD at `offset` of the TIFF data: its entries (sorted by tag), no next IFD, then the
// values that do not fit in an entry's four bytes.
inline std::string ifd(std::vector<Entry> entries, std::uint32_t offset, bool big_endian) {
  std::sort(entries.begin(), entries.end(),
            [](const Entry& a, const Entry& b) { return a.tag < b.tag; });
  std::string head = number(entries.size(), 2, big_endian), data;
  const std::uint32_t data_start = offset + 2 + 12 * static_cast<std::uint32_t>(entries.size()) + 4;
  for (const Entry& e : entries) {
    head += number(e.tag, 2, big_endian) + number(e.type, 2, big_endian) +
            number(e.count, 4, big_endian);
    if (e.value.size() <= 4) {
      head += e.value + std::string(4 - e.value.size(), '\0');  // left-justified
    } else {
      head += number(data_start + data.size(), 4, big_endian);
      data += e.value;
      if (data.size() % 2 == 1) data += '\0';  // word alignment
    }
  }
  return head + number(0, 4, big_endian) + data;
}

}  // namespace exif_detail

// The APP1 segment: FF E1, its length, "Exif\0\0" and the TIFF data (IFD0, the EXIF IFD).
inline std::string exif_app1(const ExifTags& tags) {
  using exif_detail::Entry;
  using exif_detail::number;
  const bool be = tags.big_endian;
  const auto rational = [&](std::pair<std::uint32_t, std::uint32_t> r) {
    return number(r.first, 4, be) + number(r.second, 4, be);
  };
  std::vector<Entry> exif;
  if (tags.focal_length) exif.push_back({0x920A, 5, 1, rational(*tags.focal_length)});
  if (tags.pixel_x_dimension)
    exif.push_back({0xA002, 4, 1, number(*tags.pixel_x_dimension, 4, be)});
  if (tags.focal_plane_x_resolution)
    exif.push_back({0xA20E, 5, 1, rational(*tags.focal_plane_x_resolution)});
  if (tags.focal_plane_resolution_unit)
    exif.push_back({0xA210, 3, 1, number(*tags.focal_plane_resolution_unit, 2, be)});
  if (tags.focal_length_35mm)
    exif.push_back({0xA405, 3, 1, number(*tags.focal_length_35mm, 2, be)});
  std::vector<Entry> ifd0;
  if (!tags.make.empty())
    ifd0.push_back({0x010F, 2, static_cast<std::uint32_t>(tags.make.size() + 1),
                    tags.make + std::string(1, '\0')});
  if (tags.orientation) ifd0.push_back({0x0112, 3, 1, number(*tags.orientation, 2, be)});
  // IFD0 with a placeholder pointer first, to learn its size; then the real one.
  ifd0.push_back({0x8769, 4, 1, number(0, 4, be)});
  const std::uint32_t exif_offset =
      8 + static_cast<std::uint32_t>(exif_detail::ifd(ifd0, 8, be).size());
  ifd0.back().value = number(exif_offset, 4, be);
  const std::string tiff = std::string(be ? "MM" : "II") + number(42, 2, be) + number(8, 4, be) +
                           exif_detail::ifd(ifd0, 8, be) + exif_detail::ifd(exif, exif_offset, be);
  const std::string body = std::string("Exif\0\0", 6) + tiff;
  return std::string("\xFF\xE1", 2) + number(body.size() + 2, 2, /*big_endian=*/true) + body;
}

// `jpeg` (a JPEG file's bytes) with the APP1 segment of `tags` right after its SOI marker.
inline std::string jpeg_with_exif(const std::string& jpeg, const ExifTags& tags) {
  return jpeg.substr(0, 2) + exif_app1(tags) + jpeg.substr(2);
}

}  // namespace omnipoint::test
