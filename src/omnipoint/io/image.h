#pragma once
// Image files: the optional edge module on OpenCV (compile definition OMNIPOINT_WITH_OPENCV).
// Without it, every function here throws std::runtime_error saying the library was built
// without image I/O; image_io_available() tells beforehand.
// Tensors are row-major (H, W) or (H, W, C) on the CPU, channels in RGB(A) order.
#include <ATen/core/Tensor.h>

#include <string>

namespace omnipoint::io {

bool image_io_available();

// Whether `path` has the extension of a colour image format OpenCV decodes (PNG, JPEG, WebP,
// TIFF, BMP, JPEG 2000, PNM/PGM/PPM, Sun raster; case-insensitive): the files an input folder
// contributes. Floating-point formats (EXR, HDR, PFM) are data, not photos, and are not listed.
bool has_image_extension(const std::string& path);

// Reads any format OpenCV decodes (PNG, JPEG, ...), 8- or 16-bit, grey, grey+alpha, RGB or
// RGBA, as float32 (H, W, 3) RGB in [0, 1]: grey is replicated, alpha dropped, the pixels
// are taken as stored (no EXIF rotation). Missing, corrupt or other-depth files raise
// std::runtime_error naming the path.
at::Tensor read_image(const std::string& path);

// Reads the stored values unscaled, as float32 (exact for 8/16-bit): (H, W) for grey files,
// (H, W, C) RGB(A) otherwise. For data images such as 16-bit depth PNGs in millimetres.
// 32-bit float files (TIFF, EXR where OpenCV has it) are read as they are.
at::Tensor read_image_values(const std::string& path);

// Writes a PNG atomically from (H, W) grey, (H, W, 3) RGB or (H, W, 4) RGBA:
//   uint8 -> 8-bit; bool -> 8-bit 0/255; int16/int32/int64 in [0, 65535] -> 16-bit;
//   floating in [0, 1] (clamped; NaN rejected) -> 8-bit, or 16-bit when float_bits = 16.
// Bad shapes, dtypes or values raise std::invalid_argument.
void write_image_png(const std::string& path, const at::Tensor& image, int float_bits = 8);

}  // namespace omnipoint::io
