#pragma once
// Shared pieces of the two augmentations (p2a.h, a2p.h): rotations between a source camera
// and a virtual camera that share one optical centre, and the sampling of distance maps at
// sub-pixel positions without blending across depth edges.
//
// Conventions: camera frames as docs/DESIGN.md (x right, y down, z forward). A rotation R (3, 3)
// maps virtual-camera coordinates to source-camera coordinates, X_source = R · X_virtual, so
// its third column is the virtual optical axis seen from the source. Angles in degrees:
// yaw turns the axis from +z towards +x, pitch > 0 looks up (towards −y), roll turns about
// the virtual axis — the same azimuth/elevation convention as EQUIRECTANGULAR.
#include <ATen/core/Tensor.h>

namespace omnipoint::augment {

// R = Ry(yaw) · Rx(pitch) · Rz(roll), float64 on the CPU.
at::Tensor rotation_from_angles(double yaw_deg, double pitch_deg, double roll_deg = 0.0);

struct SampledDistance {
  at::Tensor value;  // (...) the interpolated distance, 0 where not ok
  at::Tensor ok;     // (...) bool
};
// Bilinear sampling of a distance map (H, W) with a validity map (H, W) at pixels (..., 2)
// (docs/DESIGN.md pixel convention: centres at i + 0.5). A sample is ok only where its four
// neighbouring pixel centres are valid and agree in distance (max/min <= 1 + tolerance), so
// values are never blended across an occlusion edge. Positions within half a pixel of the
// border clamp to the border pixels. Positions outside [0, W] x [0, H] are not ok.
SampledDistance sample_distance(const at::Tensor& distance, const at::Tensor& valid,
                                const at::Tensor& pixels, double tolerance);

// Bilinear sampling of a floating image (H, W, C) at pixels (..., 2) with the same convention
// and clamping (grid_sample's align_corners = false with border padding). Returns (..., C) on
// the image's device.
at::Tensor sample_image(const at::Tensor& image, const at::Tensor& pixels);

}  // namespace omnipoint::augment
