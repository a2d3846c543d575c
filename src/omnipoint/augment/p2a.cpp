#include "omnipoint/augment/p2a.h"

#include <ATen/ATen.h>
#include <ATen/Dispatch.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

#include "omnipoint/augment/warp.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::augment {
namespace {

void check_inputs(const camera::Camera& source, const at::Tensor& image, const at::Tensor& distance,
                  const at::Tensor& mask, const VirtualView& target, const P2AOptions& options) {
  const std::string where = "perspective_to_any: ";
  const auto h = source.height(), w = source.width();
  if (!image.defined() || image.dim() != 3 || image.size(0) != h || image.size(1) != w ||
      image.size(2) != 3 || !at::isFloatingType(image.scalar_type())) {
    throw std::invalid_argument(where + "image must be a float (" + std::to_string(h) + ", " +
                                std::to_string(w) + ", 3) tensor matching the source camera");
  }
  if (!distance.defined() || distance.sizes() != at::IntArrayRef({h, w}) ||
      !at::isFloatingType(distance.scalar_type())) {
    throw std::invalid_argument(
        where + "distance must be a float (H, W) tensor matching the source camera");
  }
  if (!mask.defined() || mask.sizes() != distance.sizes() || mask.scalar_type() != at::kBool) {
    throw std::invalid_argument(where +
                                "mask must be a bool (H, W) tensor matching the source camera");
  }
  if (target.rotation.defined() && target.rotation.sizes() != at::IntArrayRef({3, 3})) {
    throw std::invalid_argument(where + "the rotation must be (3, 3)");
  }
  if (target.centre.defined() && target.centre.numel() != 3)
    throw std::invalid_argument(where + "the centre must have 3 entries");
  if (options.supersample < 0 || options.supersample > 8) {
    throw std::invalid_argument(where + "supersample must be in [0, 8] (0: automatic)");
  }
  if (!(options.tolerance > 0) || !(options.occlusion_margin > 0)) {
    throw std::invalid_argument(where + "tolerance and occlusion_margin must be positive");
  }
}

// Hole filling of a z-buffer (H, W): a pixel without a point (not `hit`, on the camera's
// domain) whose 3 × 3 neighbourhood holds at least 4 hits that agree in distance
// (max <= min · (1 + tolerance)) takes their mean. Returns the filled pixels; `zdistance`
// receives their values. One pass over the pixels (9 stacked shifted copies took ~1.6 s at
// 2048 × 1024 here).
at::Tensor fill_holes(at::Tensor& zdistance, const at::Tensor& hit, const at::Tensor& domain,
                      double tolerance) {
  const int64_t height = zdistance.size(0), width = zdistance.size(1);
  const auto device = zdistance.device();
  at::Tensor z_map = zdistance.to(at::kCPU).contiguous();
  const at::Tensor hits = hit.to(at::kCPU).contiguous(), usable = domain.to(at::kCPU).contiguous();
  at::Tensor filled = at::zeros({height, width}, hits.options());
  AT_DISPATCH_FLOATING_TYPES(z_map.scalar_type(), "fill_holes", [&] {
    scalar_t* z = z_map.data_ptr<scalar_t>();
    const bool* h = hits.data_ptr<bool>();
    const bool* on_domain = usable.data_ptr<bool>();
    bool* out = filled.data_ptr<bool>();
    // Holes are written, hits are read: a filled value never feeds another pixel's fill.
    util::parallel_for(
        0, height, std::max<int64_t>(1, 16384 / width), [&](int64_t begin, int64_t end) {
          for (int64_t row = begin; row < end; ++row) {
            for (int64_t col = 0; col < width; ++col) {
              const int64_t at_pixel = row * width + col;
              if (h[at_pixel] || !on_domain[at_pixel]) continue;
              int count = 0;
              scalar_t sum = 0, low = std::numeric_limits<scalar_t>::infinity(), high = -low;
              for (int64_t r = std::max<int64_t>(row - 1, 0); r <= std::min(row + 1, height - 1);
                   ++r) {
                for (int64_t c = std::max<int64_t>(col - 1, 0); c <= std::min(col + 1, width - 1);
                     ++c) {
                  if (!h[r * width + c]) continue;
                  const scalar_t value = z[r * width + c];
                  ++count;
                  sum += value;
                  low = std::min(low, value);
                  high = std::max(high, value);
                }
              }
              if (count >= 4 && high <= low * (1 + static_cast<scalar_t>(tolerance))) {
                z[at_pixel] = sum / count;
                out[at_pixel] = true;
              }
            }
          }
        });
  });
  zdistance = z_map.to(device);
  return filled.to(device);
}

// The point-wise steps between the source frame and the virtual camera's
// (X_source = R · X_virtual + c), one pass per point on the CPU: as tensor operations (a matmul
// of (N, 3) by (3, 3), norms over the length-3 last dimension) they took ~30 ms for the two
// million points of a 2048 × 1024 panorama, most of it in temporaries. `map(x, s, out)` reads
// a point's three coordinates x (N, 3) and its scalar s (N) and writes its kOutputs values; the
// result has the scalars' dtype and device.
template <int kOutputs, typename Map>
at::Tensor map_points(const at::Tensor& points, const at::Tensor& scalars, const Map& map) {
  const at::Tensor in = points.to(at::kCPU, scalars.scalar_type()).contiguous();
  const at::Tensor factor = scalars.to(at::kCPU).contiguous();
  const int64_t count = in.numel() / 3;
  std::vector<int64_t> shape(points.sizes().begin(), points.sizes().end() - 1);
  if (kOutputs > 1) shape.push_back(kOutputs);
  at::Tensor out = at::empty(shape, in.options());
  AT_DISPATCH_FLOATING_TYPES(in.scalar_type(), "p2a_map_points", [&] {
    const scalar_t* x = in.data_ptr<scalar_t>();
    const scalar_t* f = factor.data_ptr<scalar_t>();
    scalar_t* o = out.data_ptr<scalar_t>();
    util::parallel_for(0, count, 16384, [&](int64_t begin, int64_t end) {
      for (int64_t i = begin; i < end; ++i) map(x + 3 * i, f[i], o + kOutputs * i);
    });
  });
  return out.to(scalars.device());
}

// The rotation's entries and the centre, as doubles on the host.
struct Frame {
  double r[3][3];
  double c[3];
};
Frame frame_of(const at::Tensor& rotation, const at::Tensor& centre) {
  const at::Tensor r = rotation.to(at::kCPU, at::kDouble).contiguous();
  const at::Tensor c = centre.to(at::kCPU, at::kDouble).contiguous();
  Frame frame{};
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) frame.r[i][j] = r.data_ptr<double>()[3 * i + j];
    frame.c[i] = c.data_ptr<double>()[i];
  }
  return frame;
}

// Source points ray · distance (N, 3), (N) in the virtual frame, Rᵀ (X − c), with their
// distance from the virtual centre as a fourth column: (N, 4).
at::Tensor to_virtual(const at::Tensor& rays, const at::Tensor& distance, const Frame& f) {
  return map_points<4>(rays, distance, [&f](const auto* ray, auto d, auto* out) {
    using T = std::remove_const_t<std::remove_reference_t<decltype(*ray)>>;
    T shifted[3];
    for (int i = 0; i < 3; ++i) shifted[i] = ray[i] * d - static_cast<T>(f.c[i]);
    T squared = 0;
    for (int j = 0; j < 3; ++j) {
      out[j] = shifted[0] * static_cast<T>(f.r[0][j]) + shifted[1] * static_cast<T>(f.r[1][j]) +
               shifted[2] * static_cast<T>(f.r[2][j]);
      squared += out[j] * out[j];
    }
    out[3] = std::sqrt(squared);
  });
}

// Virtual rays at distances (N, 3), (N) in the source frame: c + R (ray · distance), (N, 3).
at::Tensor to_source(const at::Tensor& rays, const at::Tensor& distance, const Frame& f) {
  return map_points<3>(rays, distance, [&f](const auto* ray, auto d, auto* out) {
    using T = std::remove_const_t<std::remove_reference_t<decltype(*ray)>>;
    for (int i = 0; i < 3; ++i)
      out[i] = static_cast<T>(f.c[i]) +
               (static_cast<T>(f.r[i][0]) * ray[0] + static_cast<T>(f.r[i][1]) * ray[1] +
                static_cast<T>(f.r[i][2]) * ray[2]) *
                   d;
  });
}

// The distance from the virtual centre of the source's point at `distance` (N) along the
// direction of each source-frame point (N, 3): |X · (d / |X|) − c|, (N).
at::Tensor distance_from_centre(const at::Tensor& points, const at::Tensor& distance,
                                const Frame& f) {
  return map_points<1>(points, distance, [&f](const auto* x, auto d, auto* out) {
    using T = std::remove_const_t<std::remove_reference_t<decltype(*x)>>;
    const T along = d / std::sqrt(x[0] * x[0] + x[1] * x[1] + x[2] * x[2]);
    T squared = 0;
    for (int i = 0; i < 3; ++i) {
      const T offset = x[i] * along - static_cast<T>(f.c[i]);
      squared += offset * offset;
    }
    out[0] = std::sqrt(squared);
  });
}

// Angle between unit rays (..., 3), stable for small angles.
at::Tensor angle_between(const at::Tensor& a, const at::Tensor& b) {
  return at::atan2(at::cross(a, b, -1).norm(2, -1), (a * b).sum(-1));
}

// Solid-angle footprint (square root) of the pixels at `pixels` (..., 2).
at::Tensor pixel_angle(const camera::Camera& camera, const at::Tensor& pixels) {
  const at::Tensor centre = camera.unproject(pixels).rays;
  const at::Tensor right = camera.unproject(pixels + at::tensor({1.0, 0.0}, pixels.options())).rays;
  const at::Tensor down = camera.unproject(pixels + at::tensor({0.0, 1.0}, pixels.options())).rays;
  return at::sqrt(angle_between(centre, right) * angle_between(centre, down));
}

// How many target pixels one source pixel spans at most (a magnification), sampled on a
// 17 × 17 probe grid of the target, with a 25 % margin. 1 where nothing overlaps.
double magnification(const camera::Camera& source, const VirtualView& target,
                     const at::Tensor& rotation) {
  const auto opts = at::TensorOptions().dtype(at::kDouble);
  const at::Tensor xs = at::linspace(0.5, target.camera.width() - 1.5, 17, opts);
  const at::Tensor ys = at::linspace(0.5, target.camera.height() - 1.5, 17, opts);
  const auto grid = at::meshgrid({ys, xs}, "ij");
  const at::Tensor probes = at::stack({grid[1], grid[0]}, -1).reshape({-1, 2});
  const camera::Rays rays = target.camera.unproject(probes);
  const camera::Pixels in_source = source.project(rays.rays.matmul(rotation.to(opts).t()));
  const at::Tensor ok = rays.valid & in_source.valid & source.inside_image(in_source.pixels);
  if (!ok.any().item<bool>()) return 1.0;
  const at::Tensor ratio = pixel_angle(source, in_source.pixels.index({ok})) /
                           pixel_angle(target.camera, probes.index({ok}));
  const at::Tensor finite = ratio.masked_select(at::isfinite(ratio));
  return finite.numel() > 0 ? 1.25 * finite.max().item<double>() : 1.0;
}

}  // namespace

P2AResult perspective_to_any(const camera::Camera& source, const at::Tensor& image,
                             const at::Tensor& distance, const at::Tensor& mask,
                             const VirtualView& target, const P2AOptions& options) {
  check_inputs(source, image, distance, mask, target, options);
  const auto opts = distance.options();
  const int64_t sh = source.height(), sw = source.width();
  const int64_t th = target.camera.height(), tw = target.camera.width();
  const at::Tensor rotation =
      target.rotation.defined() ? target.rotation.to(opts) : at::eye(3, opts);
  // Automatic supersampling: the smallest s (at most 4) that leaves no gaps between splats.
  const double magnify = magnification(source, target, rotation);
  const int64_t s = options.supersample > 0
                        ? options.supersample
                        : std::clamp<int64_t>(static_cast<int64_t>(std::ceil(magnify)), 1, 4);
  // Gaps (in target pixels) that remain between neighbouring splats.
  const int64_t gap = std::clamp<int64_t>(static_cast<int64_t>(std::ceil(magnify / s)) - 1, 0, 3);
  const at::Tensor centre =
      target.centre.defined() ? target.centre.to(opts).reshape({3}) : at::zeros({3}, opts);

  // 1. Forward splatting of s × s sub-pixel points per source pixel.
  const at::Tensor xs = (at::arange(sw * s, opts) + 0.5) / static_cast<double>(s);
  const at::Tensor ys = (at::arange(sh * s, opts) + 0.5) / static_cast<double>(s);
  const auto grid = at::meshgrid({ys, xs}, "ij");
  const at::Tensor sub_pixels = at::stack({grid[1], grid[0]}, -1).reshape({-1, 2});
  const at::Tensor source_index =
      (grid[0].floor().to(at::kLong) * sw + grid[1].floor().to(at::kLong)).reshape(-1);
  const camera::Rays sub_rays = source.unproject(sub_pixels);
  // Sub-pixel distances: bilinear where the pixel quad agrees, else the pixel's own value, so
  // splats of a slanted surface are smooth and depth edges stay sharp.
  const at::Tensor own_distance = distance.reshape(-1).index_select(0, source_index);
  const SampledDistance smooth = sample_distance(distance, mask, sub_pixels, options.tolerance);
  const at::Tensor sub_distance = at::where(smooth.ok, smooth.value, own_distance);
  const at::Tensor sub_ok = sub_rays.valid & mask.reshape(-1).index_select(0, source_index) &
                            at::isfinite(sub_distance) & (sub_distance > 0);
  const Frame frame = frame_of(rotation, centre);
  const at::Tensor virtual_points = to_virtual(sub_rays.rays, sub_distance, frame);
  const camera::Pixels projected = target.camera.project(virtual_points.narrow(-1, 0, 3));
  const at::Tensor splat_distance = virtual_points.select(-1, 3);
  // The z-buffer keeps each pixel's nearest point and stores its distance.
  const geometry::SparseDepth zbuffer = geometry::rasterize_nearest(
      projected.pixels, splat_distance, splat_distance, sub_ok & projected.valid, tw, th);
  const at::Tensor hit = zbuffer.valid;
  at::Tensor zdistance = zbuffer.depth.to(opts.dtype());

  // Optional hole filling of the z-buffer: a gap whose hit neighbours agree in depth.
  const camera::Rays target_rays = target.camera.ray_map(opts);
  at::Tensor filled = options.fill_holes
                          ? fill_holes(zdistance, hit, target_rays.valid, options.tolerance)
                          : at::zeros({th, tw}, opts.dtype(at::kBool));

  // 2. Read-back along each target pixel's ray at the z-buffered distance.
  const at::Tensor surface = to_source(target_rays.rays, zdistance, frame);
  const camera::Pixels in_source = source.project(surface);
  const SampledDistance readback =
      sample_distance(distance, mask, in_source.pixels, options.tolerance);
  // The source ray through that pixel is the surface point's direction (a camera's
  // unproject ∘ project is the identity on rays), so no unprojection is needed.
  const at::Tensor target_distance = distance_from_centre(surface, readback.value, frame);
  const at::Tensor colour = sample_image(image, in_source.pixels);

  // 3. Validity: the read-back surface is the z-buffered one, inside the source frustum, and,
  // where splats leave gaps, no clearly nearer surface lies within a gap's width. The last
  // test catches a background point that won a pixel through a gap between the splats of a
  // magnified foreground: the read-back cannot, as the source may well see that background
  // point from its own position.
  at::Tensor known = (hit | filled) & target_rays.valid & in_source.valid &
                     source.inside_image(in_source.pixels) & readback.ok &
                     ((target_distance - zdistance).abs() <= options.occlusion_margin * zdistance);
  if (gap > 0) {
    const int64_t k = 2 * gap + 1;
    const double inf = std::numeric_limits<double>::infinity();  // "no point" in the min-pool
    const at::Tensor nearest_around =
        -at::max_pool2d(-at::where(hit, zdistance, at::full_like(zdistance, inf)).unsqueeze(0),
                        {k, k}, {1, 1}, {gap, gap})
             .squeeze(0);
    known = known & (zdistance <= nearest_around * (1.0 + options.occlusion_margin));
  }
  // Filled pixels carry values for the image, never labels.
  P2AResult result{target.camera, {}, target_rays.rays, {}, known & hit, known & filled};
  result.image = at::where(known.unsqueeze(-1), colour, at::zeros_like(colour));
  result.distance = at::where(known, target_distance, at::zeros_like(target_distance));
  return result;
}

}  // namespace omnipoint::augment
