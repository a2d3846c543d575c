#pragma once
// A picture of a point cloud from an oblique viewpoint (the `preview.png` of `omnipoint
// predict`), so a person sees the 3D shape without a viewer. The virtual camera orbits the
// cloud's median point by `yaw_deg` (to the right) and `pitch_deg` (from above), steps back
// until the cloud is in front of it, and frames the cloud with a pinhole; points are splatted
// as small squares into a z-buffer (nearest wins) and dimmed with distance for depth cues.
#include <ATen/core/Tensor.h>

#include <cstdint>

namespace omnipoint::predict {

struct PreviewOptions {
  int64_t width = 640;
  int64_t height = 480;
  double yaw_deg = 35.0;
  double pitch_deg = 25.0;
  int64_t max_points = 150000;  // larger clouds are subsampled regularly (the splats grow)
};

// points (N, 3) camera frame (finite), colors (N, 3) uint8 -> (height, width, 3) uint8 image,
// dark grey where no point lands.
at::Tensor render_preview(const at::Tensor& points, const at::Tensor& colors,
                          const PreviewOptions& options = {});

}  // namespace omnipoint::predict
