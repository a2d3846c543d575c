#pragma once
// A photo's EXIF facts about its camera and orientation (the APP1 segment of a JPEG), read with
// libexif (Debian's libexif-dev), the optional edge module built with image I/O
// (OMNIPOINT_WITH_OPENCV; exif_available() tells). The tags, from the EXIF standard (CIPA
// DC-008):
//   Orientation (0x0112, IFD0)          how the stored pixels are turned for display, 1..8
//   FocalLengthIn35mmFilm (0xA405)      the 35 mm film equivalent focal length in mm (0: unknown)
//   FocalLength (0x920A)                the lens's focal length in mm
//   FocalPlaneXResolution (0xA20E)      pixels per FocalPlaneResolutionUnit on the sensor, along
//   FocalPlaneResolutionUnit (0xA210)   the stored image's x: 2 inch (default), 3 cm (and the
//                                       TIFF/EP units 4 mm, 5 micrometre)
//   PixelXDimension (0xA002)            the width the focal-plane resolution refers to
// predict turns them into a camera (predict/inputs.h: camera_from_exif).
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <optional>
#include <string>

namespace omnipoint::io {

bool exif_available();

struct ExifFacts {
  bool present = false;                     // the file has EXIF data
  int orientation = 1;                      // 1 (as stored) when absent or out of 1..8
  std::optional<double> focal_length_35mm;  // mm, > 0
  std::optional<double> focal_length;       // mm, > 0
  // Sensor pixels per millimetre along the stored image's x (from the resolution and its unit),
  // and the image width it refers to (PixelXDimension; absent: the stored width).
  std::optional<double> focal_plane_pixels_per_mm;
  std::optional<std::int64_t> pixel_x_dimension;
  std::string make, model;  // the camera's, for messages ("" when absent)
};

// The EXIF facts of a file: a JPEG's; any other file, or a JPEG without EXIF, has none
// (present = false). Malformed or implausible values are left out, never an error. A file that
// cannot be read: std::runtime_error naming it. Without libexif: present = false.
ExifFacts read_exif(const std::string& path);

// Whether an Orientation value turns the image by 90 degrees (5..8): width and height swap.
bool orientation_swaps_axes(int orientation);

// The image (H, W, ...) as a photo viewer shows it, for an Orientation value: 2 mirrored left
// to right, 3 turned 180 degrees, 4 mirrored top to bottom, 5 transposed, 6 turned 90 degrees
// clockwise, 7 transposed across the other diagonal, 8 turned 90 degrees anticlockwise; 1 and
// any other value as stored. Contiguous.
at::Tensor apply_exif_orientation(const at::Tensor& image, int orientation);

}  // namespace omnipoint::io
