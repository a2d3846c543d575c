#pragma once
// Simulated sparse depth (training conditions and evaluation inputs): uniform samples of a
// dense map, LiDAR-like scan lines, noise and outliers, and LiDAR point clouds rendered
// into any camera with a z-buffer.
//
// Conventions: dense maps (..., H, W) of distances or depths (any floating dtype, any
// device), masks (..., H, W) bool, leading dimensions are batch items. Randomness comes
// from a CPU generator (e.g. at::make_generator<at::CPUGeneratorImpl>(seed)) drawn on the
// CPU over the full map shape, so a seed gives the same samples on every device.
#include <ATen/core/Generator.h>
#include <ATen/core/Tensor.h>

#include <cstdint>

#include "omnipoint/camera/camera.h"

namespace omnipoint::geometry {

struct SparseDepth {
  at::Tensor depth;  // (..., H, W) the sampled values; zero elsewhere
  at::Tensor valid;  // (..., H, W) bool: the sample locations
};

// `count` pixels per item, uniformly without replacement among the valid pixels (all of
// them where an item has fewer). The paper evaluates with 1,000.
SparseDepth sample_uniform(const at::Tensor& dense, const at::Tensor& valid, std::int64_t count,
                           at::Generator generator);
// A share `ratio` in (0, 1] of each item's valid pixels (rounded, at least one where the
// item has valid pixels), uniformly without replacement. The paper trains with 0.05–0.1 %.
SparseDepth sample_uniform_ratio(const at::Tensor& dense, const at::Tensor& valid, double ratio,
                                 at::Generator generator);

// A rotating LiDAR at the camera centre, spinning about the camera's vertical axis (y):
// `beams` scan lines at elevations evenly spaced over [min, max] (up positive) and
// `azimuth_steps` firings per revolution. Defaults resemble a 64-beam automotive sensor.
struct LidarPattern {
  std::int64_t beams = 64;
  double min_elevation_deg = -24.9;
  double max_elevation_deg = 2.0;
  std::int64_t azimuth_steps = 2000;
};
// The samples a LiDAR of `pattern` would return, read from the dense map: for every beam
// direction, the pixel whose ray (from `rays` (H, W, 3) or (..., H, W, 3), unit, zero where
// invalid — any camera model) is angularly nearest, kept when the direction falls inside
// that pixel's footprint and the pixel is valid. Vectorised (a minimum per beam over the pixels).
SparseDepth sample_lidar(const at::Tensor& dense, const at::Tensor& valid, const at::Tensor& rays,
                         const LidarPattern& pattern = {});

struct DepthNoise {
  double relative_sigma = 0.0;      // value · exp(σ·n), n ~ N(0, 1): multiplicative noise
  double outlier_ratio = 0.0;       // probability that a sample is an outlier
  double outlier_max_factor = 3.0;  // outliers: value · f, log f ~ U(−log F, log F)
};
// Perturbs the sampled values (locations unchanged).
SparseDepth add_noise(const SparseDepth& sparse, const DepthNoise& noise, at::Generator generator);

enum class SparseValue { Distance, PlanarDepth };

// Z-buffer rasterisation of projected points: pixels (..., N, 2) (x, y in the pixel
// convention of docs/DESIGN.md), their distances (..., N) from the camera, the values to store
// (..., N) and a validity (..., N). Each image pixel [i, i+1) x [j, j+1) keeps the value of
// its nearest point (ties: the smallest value). Points outside the image, invalid or with
// non-finite or non-positive distance are dropped. Returns (..., height, width). One pass
// over the points on the CPU (other devices' tensors go there and the result comes back).
SparseDepth rasterize_nearest(const at::Tensor& pixels, const at::Tensor& distance,
                              const at::Tensor& value, const at::Tensor& valid, std::int64_t width,
                              std::int64_t height);

// A sparse map (H, W) (0 or non-finite: no sample) at another size: each sample moves to the
// pixel of the new size that holds its pixel centre, and a pixel receiving several keeps the
// smallest (the nearest surface). Unlike resizing it as an image, no sample is lost to the
// subsampling grid and none is blended with its neighbours. Planar depths stay those of the
// original pixel centres (at most half a source pixel away).
at::Tensor resize_sparse_map(const at::Tensor& map, std::int64_t width, std::int64_t height);

// Which of the points that project into a pixel gives its sample (sparse_depth_from_points).
//
// kNearest: a z-buffer, the nearest point (the rule of datasets' own LiDAR labels).
//
// kSensorSweep: a sensor's returns (a LiDAR sweep) as samples of the surface the camera sees at
// its pixel centres, to compare with a dense prediction there. Two parts:
// - Occlusion: a sweep taken from another centre than the camera's (a LiDAR beside it) holds
//   returns from surfaces the camera does not see; they project onto the nearer surface that
//   hides them, among that surface's own returns. A return is dropped when a return in its
//   image neighbourhood is nearer to the camera by more than (1 + radius) · `occlusion_margin`
//   of its distance. The neighbourhood is the smallest square window (radius 0, 1, ...
//   `max_radius` pixels) holding at least `min_neighbours` other returns: the pixel alone where
//   the sweep is denser than the pixels, as wide as the gaps between its scan lines where it is
//   sparser, so that a hidden return always has the hiding surface's returns to be compared
//   with. The margin is the depth step taken as an occluding edge; it grows with the window as
//   a smooth surface's change across it does, which stays below it unless the surface is seen
//   near grazing (at 10 % per pixel of radius: within about 15° of grazing for 3° pixels, 45°
//   for 2.5° windows of radius 3 at 1.6° pixels). An occluder nearer than the margin to what it
//   hides is not detected; visible returns within the window of a nearer surface's edge are
//   dropped as well.
// - Choice: among a pixel's remaining returns, the one projecting nearest to the pixel centre
//   (ties: the smallest value), not the nearest to the camera: where many returns share a
//   pixel, the nearest is the one at the pixel's near edge on any slanted surface, a bias of up
//   to the distance's change across the pixel.
enum class PointSelection { kNearest, kSensorSweep };
struct SweepOcclusion {
  double occlusion_margin = 0.1;  // relative depth step per pixel of window radius (above)
  int64_t min_neighbours = 3;     // returns besides its own that a window must hold
  int64_t max_radius = 8;         // pixels: the widest window

  // std::invalid_argument, one line, for a margin not in (0, 1), neighbours < 1 or radius < 0.
  void Check() const;
};

// A point cloud in the camera frame (..., N, 3) (e.g. LiDAR after its extrinsics), with an
// optional validity (..., N) for padded batches, as a sparse map through any camera model:
// Camera::project, then one sample per pixel by `selection` (above). Stores distances (default)
// or planar depth z.
SparseDepth sparse_depth_from_points(const at::Tensor& points, const camera::Camera& camera,
                                     const at::Tensor& valid = {},
                                     SparseValue value = SparseValue::Distance,
                                     PointSelection selection = PointSelection::kNearest,
                                     const SweepOcclusion& occlusion = {});

}  // namespace omnipoint::geometry
