#pragma once
// Any-to-Perspective (A2P, paper §3.4): pseudo-labels for unlabeled wide-FoV images from a
// perspective-capable teacher. One virtual pinhole view is cut out of the wide image
// (inverse warping, bilinear), the teacher predicts its geometry, and the prediction goes
// back into the wide frame: every wide pixel whose ray falls inside the view reads the
// teacher's distance there (warp.h sample_distance: no blending across depth edges). The
// view and the wide camera share the optical centre, so a distance is a distance in both.
//
// The same machinery over several views that tile the sphere (or a fisheye's FoV), merged
// scale-consistently, gives wide-FoV inference from a perspective-only model
// (predict_wide_from_views).
//
// Shapes: images (H, W, 3) float in [0, 1]; distances (H, W); masks (H, W) bool.
#include <ATen/core/Generator.h>
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <functional>
#include <vector>

#include "omnipoint/camera/camera.h"

namespace omnipoint::augment {

// A virtual pinhole inside a wide camera: rotation (3, 3) maps view -> wide coordinates.
struct PerspectiveView {
  camera::Camera camera;
  at::Tensor rotation;
};
// A centred pinhole of horizontal `fov_deg` looking along (yaw, pitch) (warp.h angles).
PerspectiveView make_perspective_view(double fov_deg, double yaw_deg, double pitch_deg,
                                      int64_t width, int64_t height, double roll_deg = 0.0);

struct A2PViewDistribution {
  double min_fov_deg = 50, max_fov_deg = 100;
  int64_t min_size = 384, max_size = 640;  // the view's longer side; aspect from [3/4, 4/3]
  double max_pitch_deg = 45;               // yaw: any within the wide camera's coverage
};
// ONE random view whose axis the wide camera sees (its centre ray projects into the image).
PerspectiveView sample_perspective_view(const camera::Camera& wide,
                                        const A2PViewDistribution& distribution,
                                        at::Generator generator);

struct ExtractedView {
  at::Tensor image;  // (h, w, C) bilinear samples of the wide image; 0 where invalid
  at::Tensor valid;  // (h, w) bool: the view ray is seen by the wide camera (and its mask)
};
// Inverse warp of a wide image (H, W, C) into the view; `wide_valid` (H, W) bool optional
// (e.g. a fisheye's lens circle).
ExtractedView extract_view(const camera::Camera& wide, const at::Tensor& image,
                           const PerspectiveView& view, const at::Tensor& wide_valid = {});

// A teacher's prediction for a pinhole image: rays (h, w, 3) in the view frame, distances
// (h, w) along them (metric or up to scale), confident (h, w) bool.
struct TeacherPrediction {
  at::Tensor rays;
  at::Tensor distance;
  at::Tensor confident;
};
using Teacher =
    std::function<TeacherPrediction(const at::Tensor& image, const camera::Camera& camera)>;

struct PseudoLabel {
  at::Tensor distance;  // (H, W) along the wide camera's rays; 0 outside mask
  at::Tensor mask;      // (H, W) bool
};
// Stitches a view's predicted distance back into the wide frame: only wide pixels whose
// rays land inside the view (in front of it) on confident, depth-consistent predictions.
PseudoLabel stitch_view(const camera::Camera& wide, const PerspectiveView& view,
                        const TeacherPrediction& prediction, double tolerance = 0.05);

struct A2PResult {
  PerspectiveView view;
  ExtractedView extracted;
  TeacherPrediction prediction;
  PseudoLabel label;
};
// The training-time A2P step: extract one view, run the teacher, stitch the label back. The
// label mask also requires the view pixel to be seen by the wide camera.
A2PResult any_to_perspective(const camera::Camera& wide, const at::Tensor& image,
                             const PerspectiveView& view, const Teacher& teacher,
                             const at::Tensor& wide_valid = {}, double tolerance = 0.05);

struct MultiViewOptions {
  double fov_deg = 100;  // each view's horizontal and vertical FoV (square views)
  int64_t view_size = 518;
  double tolerance = 0.05;
  int64_t min_overlap = 64;  // pixels of overlap needed to align a view's scale
};
// Views whose union covers the wide camera: for a full panorama a ring of 8 at the horizon,
// rings of 4 at ±60° and the two poles; for other cameras the subset whose axes it sees.
std::vector<PerspectiveView> tiling_views(const camera::Camera& wide,
                                          const MultiViewOptions& options = {});

struct MergedPrediction {
  at::Tensor distance;              // (H, W) in the scale of the first (largest) view
  at::Tensor mask;                  // (H, W) bool
  std::vector<double> view_scales;  // the factor applied to each view (1 for the reference)
};
// Wide-FoV inference from a perspective-only teacher: every view is predicted and stitched;
// views are taken in order of overlap with what is merged so far, each rescaled by the
// median ratio merged / view over the overlap (robust to outliers), then blended with
// weights that fall off towards the view's border. A view that overlaps nothing keeps its
// own scale.
MergedPrediction predict_wide_from_views(const camera::Camera& wide, const at::Tensor& image,
                                         const Teacher& teacher,
                                         const MultiViewOptions& options = {},
                                         const at::Tensor& wide_valid = {});

}  // namespace omnipoint::augment
