#pragma once
// UniK3D's camera JSON (github.com/lpiccinelli-eth/UniK3D, unik3d/utils/camera.py and
// assets/demo/*.json): {"name": CLASS, "params": [...]}, read as our models, exactly.
//
// Its pixel coordinates are ours (pixel centres at i + 0.5: its coords_grid), so principal
// points carry over unchanged. Its tangential terms act on the *radially distorted* point
// (OpenCV's act on the undistorted one), and its index 10 (OPENCV), 6 (MEI), p0 (Fisheye624)
// multiplies r² + 2x² in x, the role of OpenCV's p2.
//   CLASS       UniK3D params                                  ours
//   Pinhole     fx fy cx cy                                    PINHOLE fx fy cx cy
//   OPENCV      fx fy cx cy k1..k6 p1 p2 s1..s4 (16)           OPENCV fx fy cx cy k1 k2 p2 p1,
//                                                              FULL_OPENCV when k3 != 0
//   Fisheye624  fx fy cx cy k0..k5 p0 p1 s0..s3 (16)           RAD_TAN_THIN_PRISM_FISHEYE as is,
//                                                              OPENCV_FISHEYE fx fy cx cy k0..k3
//                                                              when k4 k5 p s are all 0
//   MEI         fx fy cx cy k1 k2 p1 p2 xi                     MEI fx fy cx cy xi k1 k2 p2 p1
//   EUCM        fx fy cx cy alpha beta                         EUCM as is
//   Spherical   fx fy cx cy W H hfov/2 vfov/2 (fx..cy unused)  EQUIRECTANGULAR W H with
//                                                              -hfov/2 hfov/2 -vfov/2 vfov/2
// Not representable, hence errors naming the terms: OPENCV with thin-prism terms (s1..s4) or
// the rational k4..k6 (which UniK3D's OPENCV refuses too); OPENCV or MEI with both radial and
// tangential terms (the order of the two differs from OpenCV's).
// Spherical keeps the fields of view its parameters name: its own formula spaces the pixel
// centres hfov / (W - 1) apart from (W - 1) / 2, ours hfov / W from W / 2, so the rays differ by
// at most one pixel's angle at the right and bottom borders (0.6 degrees on its 612-pixel demo
// panorama); this makes a 360-degree Spherical a full panorama.
#include <optional>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"

namespace omnipoint::camera {

// The size comes from the parameters (Spherical), else from `image_size`; without either, an
// error says to give one. Errors (std::invalid_argument) name the class and the problem.
Camera camera_from_unik3d(const std::string& class_name, const std::vector<double>& params,
                          std::optional<ImageSize> image_size);

}  // namespace omnipoint::camera
