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
// A pair's log ratio is a measurement of log s_i - log s_j (its negative is what it asks of them),
// with a standard error from its pixels. Their errors are correlated by `pixel_correlation` (rho):
// a part common to all of them — the network's error over that region of the image, which the
// pixels' spread does not show — and a part of each pixel's own, which the spread (1.4826 x the
// inliers' median absolute deviation) shows and which averages out over the n inliers. The
// standard error is therefore spread x sqrt(rho / (1 - rho) + 1 / n): a large overlap does not
// average away an error the network made over all of it. The two orders of a pair see the same
// overlap: each carries half its weight.
//
// The cameras' log-scales are solved jointly by weighted least squares: the counted pairs, and for
// each camera without an anchor its network scale as a prior — its log-scale relative to its
// group's level is 0 with standard deviation `prior_sigma` (a network's metric scale is off by a
// different factor per image; the level that all of a group share is the gauge, below). Weak
// evidence (few pixels, a wide spread) therefore moves a camera little, strong evidence moves it
// to where the pair says. A pair whose residual is beyond `huber` standard errors is downweighted
// (Huber's weight, by iterated reweighting), so one bad pair cannot drag a camera. A camera's
// distance is measured from its own centre, so a scale moves the other camera's view of a point by
// less than the scale; each round re-measures the pairs at the scales so far, until no log-scale
// moves more than `tolerance`. Anchored cameras (LiDAR-aligned: their scale was measured) do not
// move. A group of cameras linked by counted pairs without an anchor is only determined up to one
// factor (the pairs and the priors are relative): its level is OverlapOptions::free_group_scale,
// else the median of its cameras' corrections is 1 (each camera's own scale is one estimate of the
// group's level; the median of them decides). Where the pairs are exact (distances right up to a
// factor per camera) their spread is ~0, their weight overrules the priors and the rule recovers
// the factors exactly.
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
// Standard deviation of a camera's network log metric scale about the rig's level: a monocular
// network's metric scale is typically off by 10 - 30 % per image (log 0.2 is 22 %).
constexpr double kOverlapPriorSigma = 0.2;
// Correlation of two overlap pixels' errors: a network's depth error is mostly smooth over a
// region of the image, common to a pair's pixels, so a pair's standard error is at least
// sqrt(0.99 / 0.01) = 10 x the spread its pixels show. (The bundled model's pairs at true scales,
// tests/predict/test_rig_predict.cpp's rig: RMS log ratio 13 x their RMS spread.)
constexpr double kOverlapPixelCorrelation = 0.99;
// Residual (in standard errors) beyond which a pair is downweighted (Huber).
constexpr double kOverlapHuber = 2.0;
// The least spread a pair's pixels are taken to have (log): float distances and the triangle
// interpolation between pixels are exact to about this, so an exact pair is not infinitely sure.
constexpr double kOverlapMinSpread = 1e-4;

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
  int64_t min_pixels = kOverlapMinPixels;               // see kOverlapMinPixels
  double band = kOverlapBand;                           // see kOverlapBand
  double prior_sigma = kOverlapPriorSigma;              // see kOverlapPriorSigma
  double pixel_correlation = kOverlapPixelCorrelation;  // see kOverlapPixelCorrelation, in [0, 1)
  double huber = kOverlapHuber;                         // see kOverlapHuber
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
  double spread = 0;     // of the inliers' log ratios: 1.4826 x their median absolute deviation
  double sigma = 0;      // its standard error (log): spread x sqrt(rho / (1 - rho) + 1 / inliers)
  double weight = 0;     // the robust weight it ended with: 1, less where it disagreed (Huber)
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
