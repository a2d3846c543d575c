#include "omnipoint/io/exif.h"

#include <ATen/ATen.h>

#include <cmath>
#include <filesystem>
#include <stdexcept>

#include "omnipoint/io/file_name.h"

#ifdef OMNIPOINT_WITH_EXIF
#include <libexif/exif-data.h>
#include <libexif/exif-loader.h>

#include <memory>
#endif

namespace omnipoint::io {

#ifdef OMNIPOINT_WITH_EXIF
namespace {

struct ExifDataDeleter {
  void operator()(ExifData* data) const { exif_data_unref(data); }
};
struct ExifLoaderDeleter {
  void operator()(ExifLoader* loader) const { exif_loader_unref(loader); }
};

// One tag's entry of an IFD, holding at least one value of `format`; null otherwise.
const ExifEntry* entry(const ExifData* data, ExifIfd ifd, ExifTag tag, ExifFormat format) {
  const ExifEntry* e = exif_content_get_entry(data->ifd[ifd], tag);
  if (e == nullptr || e->format != format || e->components < 1 || e->data == nullptr ||
      e->size < exif_format_get_size(format))
    return nullptr;
  return e;
}

std::optional<double> unsigned_number(const ExifData* data, ExifIfd ifd, ExifTag tag) {
  const ExifByteOrder order = exif_data_get_byte_order(const_cast<ExifData*>(data));
  if (const ExifEntry* e = entry(data, ifd, tag, EXIF_FORMAT_SHORT))
    return exif_get_short(e->data, order);
  if (const ExifEntry* e = entry(data, ifd, tag, EXIF_FORMAT_LONG))
    return exif_get_long(e->data, order);
  if (const ExifEntry* e = entry(data, ifd, tag, EXIF_FORMAT_RATIONAL)) {
    const ExifRational r = exif_get_rational(e->data, order);
    if (r.denominator != 0) return static_cast<double>(r.numerator) / r.denominator;
  }
  return std::nullopt;
}

// A value that must be positive and finite to mean anything (0 means "unknown" in EXIF).
std::optional<double> positive(std::optional<double> value) {
  if (value && *value > 0 && std::isfinite(*value)) return value;
  return std::nullopt;
}

std::string text(const ExifData* data, ExifTag tag) {
  const ExifEntry* e = entry(data, EXIF_IFD_0, tag, EXIF_FORMAT_ASCII);
  if (e == nullptr) return "";
  std::string value(reinterpret_cast<const char*>(e->data), e->size);
  value.erase(value.find_last_not_of(std::string(" \0", 2)) + 1);
  return value;
}

// Millimetres per FocalPlaneResolutionUnit.
std::optional<double> unit_mm(std::optional<double> unit) {
  if (!unit || *unit == 2) return 25.4;  // inch, the standard's default
  if (*unit == 3) return 10.0;
  if (*unit == 4) return 1.0;
  if (*unit == 5) return 1e-3;
  return std::nullopt;  // 1: no absolute unit
}

}  // namespace

bool exif_available() {
  return true;
}

ExifFacts read_exif(const std::string& path) {
  ExifFacts facts;
  const std::string extension = lower_extension(path);
  if (extension != ".jpg" && extension != ".jpeg" && extension != ".jpe") return facts;
  if (!std::filesystem::is_regular_file(path)) throw std::runtime_error(path + ": no such file");
  const std::unique_ptr<ExifLoader, ExifLoaderDeleter> loader(exif_loader_new());
  exif_loader_write_file(loader.get(), path.c_str());
  const unsigned char* bytes = nullptr;
  unsigned int size = 0;
  exif_loader_get_buf(loader.get(), &bytes, &size);
  if (bytes == nullptr || size == 0) return facts;
  // Read as written: libexif's default would add the standard's mandatory tags with default
  // values, which would read as facts.
  const std::unique_ptr<ExifData, ExifDataDeleter> data(exif_data_new());
  exif_data_unset_option(data.get(), EXIF_DATA_OPTION_FOLLOW_SPECIFICATION);
  exif_data_load_data(data.get(), bytes, size);
  const ExifData* d = data.get();
  facts.present = true;
  if (const auto orientation = unsigned_number(d, EXIF_IFD_0, EXIF_TAG_ORIENTATION);
      orientation && *orientation >= 1 && *orientation <= 8)
    facts.orientation = static_cast<int>(*orientation);
  facts.focal_length_35mm =
      positive(unsigned_number(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH_IN_35MM_FILM));
  facts.focal_length = positive(unsigned_number(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_LENGTH));
  const std::optional<double> resolution =
      positive(unsigned_number(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_X_RESOLUTION));
  const std::optional<double> unit =
      unit_mm(unsigned_number(d, EXIF_IFD_EXIF, EXIF_TAG_FOCAL_PLANE_RESOLUTION_UNIT));
  if (resolution && unit) facts.focal_plane_pixels_per_mm = *resolution / *unit;
  if (const auto width = positive(unsigned_number(d, EXIF_IFD_EXIF, EXIF_TAG_PIXEL_X_DIMENSION)))
    facts.pixel_x_dimension = static_cast<std::int64_t>(*width);
  facts.make = text(d, EXIF_TAG_MAKE);
  facts.model = text(d, EXIF_TAG_MODEL);
  return facts;
}

#else

bool exif_available() {
  return false;
}

ExifFacts read_exif(const std::string&) {
  return {};
}

#endif

bool orientation_swaps_axes(int orientation) {
  return orientation >= 5 && orientation <= 8;
}

at::Tensor apply_exif_orientation(const at::Tensor& image, int orientation) {
  if (image.dim() < 2)
    throw std::invalid_argument("apply_exif_orientation: expected an image (H, W, ...), got " +
                                c10::str(image.sizes()));
  switch (orientation) {
    case 2:
      return image.flip({1}).contiguous();
    case 3:
      return image.flip({0, 1}).contiguous();
    case 4:
      return image.flip({0}).contiguous();
    case 5:
      return image.transpose(0, 1).contiguous();
    case 6:
      return image.transpose(0, 1).flip({1}).contiguous();
    case 7:
      return image.transpose(0, 1).flip({0, 1}).contiguous();
    case 8:
      return image.transpose(0, 1).flip({0}).contiguous();
    default:
      return image.contiguous();
  }
}

}  // namespace omnipoint::io
