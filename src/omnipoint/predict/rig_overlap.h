#pragma once
// The overlap rule of a rig (docs/RIG.md): the same 3-D region seen by two cameras must come out
// at the same distance, so where the cameras' views overlap their scales can be reconciled
// without LiDAR. A pure function of the per-camera predictions and the rig's poses.
//
// One directed pair (i, j) is measured so: every valid pixel of camera j, as a point in the body
// frame (its ray times its distance, through body_from_camera), is taken into camera i's frame
// and projected through camera i's model (camera::Camera::project: fisheyes beyond 180 degrees and
// panoramas included). Where it lands between four valid pixels of i, i's surface there is the
// triangle of those pixels' points that the landing point falls in (the pixel square split along
// its diagonal), met by the ray from i's centre through j's point: exact on a plane, wherever in
// the pixel the point lands. The pixel's log ratio is log |i's point| - log |j's point|, both
// from i's centre. The four pixels must agree with each other within the band (no depth edge
// between them), and the triangle must not be seen edge-on (within 85 degrees of facing). The
// pair's log ratio is the median over its pixels, taken again over the pixels within the band of
// the first median (what i sees in front of j's surface — an occlusion — drops out); a pair
// counts when at least `min_pixels` pixels are within the band.
//
// The cameras' log-scales are solved jointly, least squares over the counted pairs' log ratios
// (each pair: log s_i - log s_j = -its log ratio). A camera's distance is measured from its own
// centre, so a scale moves the other camera's view of a point by less than the scale; the
// solution is iterated (each step re-measures the pairs at the scales so far) until the pairs'
// ratios are 1. Anchored cameras (LiDAR-aligned: their scale was measured) do not move. A group of
// cameras linked by counted pairs without an anchor is only determined up to one factor: its
// level is OverlapOptions::free_group_scale, else the median of its cameras' corrections is 1
// (each camera's own scale is one estimate of the group's level; the median of them decides).
#include <ATen/core/Tensor.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "omnipoint/camera/camera.h"

namespace omnipoint::predict {

// Pixels a pair needs within the band to count: fewer is too little overlap to read a scale
// from (a few pixels along an edge).
constexpr int64_t kOverlapMinPixels = 50;
// Log-ratio band around a pair's first median (and across the four pixels blended): exp(0.15) =
// 16 % covers a network's relative depth error over a shared surface, not a foreground object
// that one camera sees in front of the other's surface.
constexpr double kOverlapBand = 0.15;

// One camera's prediction, as the overlap rule reads it.
struct OverlapCamera {
  camera::Camera camera;        // the camera at the prediction's size (W, H of `distance`)
  at::Tensor body_from_camera;  // (4, 4) or (3, 4): a point in the camera's frame -> body frame
  at::Tensor rays;              // (H, W, 3) unit rays
  at::Tensor distance;          // (H, W) distance at the camera's current scale
  at::Tensor mask;              // (H, W) bool: valid pixels
  double scale = 1;             // that current scale (its factor from network distances to metres)
  bool anchored = false;        // its scale is measured (LiDAR): the rule does not move it
};

struct OverlapOptions {
  int64_t min_pixels = kOverlapMinPixels;  // see kOverlapMinPixels
  double band = kOverlapBand;              // see kOverlapBand
  // The scale a group of reconciled cameras without an anchor is levelled to (the median of its
  // cameras' final scales); unset: the median of the group's corrections is 1.
  std::optional<double> free_group_scale;
  int max_iterations = 50;  // re-measurements of the pairs
  double tolerance = 1e-9;  // stop when no log-scale moves more than this

  // std::invalid_argument with one line for a value out of range.
  void Check() const;
};

// One counted directed pair at the final scales.
struct OverlapPair {
  size_t i = 0, j = 0;   // camera i sees camera j's points
  int64_t pixels = 0;    // j's pixels that land on i's valid pixels
  int64_t inliers = 0;   // of them within the band of the pair's median
  double log_ratio = 0;  // median over the inliers of log |i's point| - log |j's point|
  double residual = 0;   // median over all `pixels` of | |i's point| / |j's point| - 1 |
};

struct OverlapResult {
  std::vector<double> factors;     // per camera: multiply its distances and scale by it
  std::vector<bool> reconciled;    // per camera: not anchored, and in a counted pair
  std::vector<int> group;          // per camera: its group of linked cameras, -1 in no pair
  std::vector<OverlapPair> pairs;  // the counted pairs, measured at the final scales
  // The disagreement left: the median over every overlapping pixel of every counted pair (the
  // pairs' `pixels`, occlusions included) of | |i's point| / |j's point| - 1 |, at the final
  // scales. Unset when no pair counts.
  std::optional<double> residual;
};

// Measures the overlaps at the cameras' current scales without moving them (factors 1): the
// counted pairs and the residual that are left, e.g. after another rule set the scales.
OverlapResult measure_overlaps(const std::vector<OverlapCamera>& cameras,
                               const OverlapOptions& options = {});

// Reconciles the cameras' scales from their overlaps (see the top).
OverlapResult reconcile_overlap_scales(const std::vector<OverlapCamera>& cameras,
                                       const OverlapOptions& options = {});

}  // namespace omnipoint::predict
