#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/geometry/sparse_sampling.h"

using namespace omnipoint::geometry;
using omnipoint::camera::make_camera;

namespace {

at::Generator seeded(uint64_t seed) {
  return at::make_generator<at::CPUGeneratorImpl>(seed);
}

struct Dense {
  at::Tensor depth, valid;
};

Dense random_dense(int64_t b, int64_t h, int64_t w, double valid_share, uint64_t seed) {
  auto g = seeded(seed);
  return {at::rand({b, h, w}, g, at::kDouble) * 20 + 0.5,
          at::rand({b, h, w}, g, at::kDouble) < valid_share};
}

}  // namespace

TEST(SparseSampling, UniformCountIsExactAndDeterministic) {
  auto dense = random_dense(3, 60, 80, 0.7, 1);
  dense.valid[2].zero_();
  dense.valid[2][5].slice(0, 0, 10).fill_(true);  // only 10 valid pixels in item 2
  auto a = sample_uniform(dense.depth, dense.valid, 1000, seeded(42));
  EXPECT_EQ(a.valid[0].sum().item<int64_t>(), 1000);
  EXPECT_EQ(a.valid[1].sum().item<int64_t>(), 1000);
  EXPECT_EQ(a.valid[2].sum().item<int64_t>(), 10);
  EXPECT_FALSE(a.valid.logical_and(dense.valid.logical_not()).any().item<bool>());
  EXPECT_TRUE(at::equal(a.depth, at::where(a.valid, dense.depth, at::zeros_like(dense.depth))));
  auto b = sample_uniform(dense.depth, dense.valid, 1000, seeded(42));
  EXPECT_TRUE(at::equal(a.valid, b.valid));
  auto c = sample_uniform(dense.depth, dense.valid, 1000, seeded(43));
  EXPECT_FALSE(at::equal(a.valid, c.valid));
  EXPECT_EQ(sample_uniform(dense.depth, dense.valid, 0, seeded(1)).valid.sum().item<int64_t>(), 0);
  EXPECT_THROW(sample_uniform(dense.depth, dense.valid, -1, seeded(1)), std::invalid_argument);
  EXPECT_THROW(sample_uniform(dense.depth, dense.valid.slice(0, 0, 1), 5, seeded(1)),
               std::invalid_argument);
}

TEST(SparseSampling, UniformRatio) {
  auto dense = random_dense(2, 100, 200, 0.5, 2);
  for (double ratio : {0.0005, 0.001, 0.3}) {
    auto s = sample_uniform_ratio(dense.depth, dense.valid, ratio, seeded(7));
    for (int64_t i = 0; i < 2; ++i) {
      const double available = dense.valid[i].sum().item<double>();
      EXPECT_EQ(s.valid[i].sum().item<int64_t>(),
                std::max<int64_t>(1, std::llround(available * ratio)));
    }
  }
  EXPECT_THROW(sample_uniform_ratio(dense.depth, dense.valid, 0.0, seeded(1)),
               std::invalid_argument);
  EXPECT_THROW(sample_uniform_ratio(dense.depth, dense.valid, 1.5, seeded(1)),
               std::invalid_argument);
  // Items without valid pixels give no samples.
  auto none = sample_uniform_ratio(dense.depth, at::zeros_like(dense.valid), 0.01, seeded(1));
  EXPECT_FALSE(none.valid.any().item<bool>());
}

TEST(SparseSampling, UniformIsUniform) {
  // 4,000 items of 4 valid pixels (of 6), one sample each: every valid pixel ~1,000 times.
  auto depth = at::ones({4000, 2, 3});
  auto valid = at::tensor({1, 1, 0, 1, 0, 1})
                   .to(at::kBool)
                   .view({1, 2, 3})
                   .expand({4000, 2, 3})
                   .contiguous();
  auto s = sample_uniform(depth, valid, 1, seeded(9));
  auto hits = s.valid.sum(0).to(at::kDouble);
  EXPECT_EQ(hits[0][2].item<double>(), 0);
  EXPECT_EQ(hits[1][1].item<double>(), 0);
  for (auto [r, c] : {std::pair{0, 0}, {0, 1}, {1, 0}, {1, 2}}) {
    EXPECT_NEAR(hits[r][c].item<double>(), 1000, 5 * std::sqrt(1000 * 0.75)) << r << "," << c;
  }
}

TEST(SparseSampling, NoiseAndOutliers) {
  auto dense = random_dense(1, 200, 200, 1.0, 3);
  auto s = sample_uniform(dense.depth, dense.valid, 20000, seeded(4));
  auto noisy = add_noise(s, DepthNoise{0.05, 0.0, 3.0}, seeded(5));
  EXPECT_TRUE(at::equal(noisy.valid, s.valid));
  auto log_ratio = (noisy.depth.masked_select(s.valid) / s.depth.masked_select(s.valid)).log();
  EXPECT_NEAR(log_ratio.std().item<double>(), 0.05, 0.002);
  EXPECT_NEAR(log_ratio.mean().item<double>(), 0.0, 0.002);
  EXPECT_TRUE(noisy.depth.masked_select(s.valid.logical_not()).eq(0).all().item<bool>());
  auto outliers = add_noise(s, DepthNoise{0.0, 0.1, 4.0}, seeded(6));
  auto ratio = outliers.depth.masked_select(s.valid) / s.depth.masked_select(s.valid);
  const double share = (ratio - 1).abs().gt(1e-12).to(at::kDouble).mean().item<double>();
  EXPECT_NEAR(share, 0.1, 0.01);
  EXPECT_LE(ratio.max().item<double>(), 4.0 + 1e-9);
  EXPECT_GE(ratio.min().item<double>(), 0.25 - 1e-9);
  EXPECT_TRUE(at::equal(add_noise(s, DepthNoise{0.05, 0.1, 4.0}, seeded(8)).depth,
                        add_noise(s, DepthNoise{0.05, 0.1, 4.0}, seeded(8)).depth));
  EXPECT_THROW(add_noise(s, DepthNoise{-1.0, 0.0, 3.0}, seeded(1)), std::invalid_argument);
}

TEST(SparseSampling, LidarScanLinesOnAPinholeCamera) {
  // A 90° pinhole camera; 16 beams over [-15°, 15°], 1° azimuth steps. Every beam direction
  // inside the image must give a sample on the pixel it projects to (within one pixel: the
  // angularly nearest pixel centre and the containing pixel can differ at pixel borders).
  const int64_t w = 320, h = 240;
  const double f = w / 2.0;
  auto camera = make_camera("PINHOLE", w, h, {f, f, w / 2.0, h / 2.0});
  auto rays = camera.ray_map(at::kDouble);
  auto depth = at::full({h, w}, 5.0, at::kDouble);
  LidarPattern pattern{16, -15.0, 15.0, 360};
  auto s = sample_lidar(depth, rays.valid, rays.rays, pattern);
  std::vector<std::pair<double, double>> expected;
  for (int64_t k = 0; k < 16; ++k) {
    const double el = (-15.0 + 2.0 * k) * M_PI / 180;
    for (int64_t j = -60; j <= 60; ++j) {
      const double az = j * M_PI / 180;
      const double x = std::cos(el) * std::sin(az), y = -std::sin(el),
                   z = std::cos(el) * std::cos(az);
      const double u = f * x / z + w / 2.0, v = f * y / z + h / 2.0;
      if (u >= 1 && u < w - 1 && v >= 1 && v < h - 1) expected.emplace_back(u, v);
    }
  }
  ASSERT_GT(expected.size(), 1000u);
  auto hits = s.valid.nonzero();  // (M, 2) rows, cols
  EXPECT_NEAR(static_cast<double>(hits.size(0)), static_cast<double>(expected.size()), 2 * 16);
  auto hit_rows = hits.select(1, 0).to(at::kDouble) + 0.5,
       hit_cols = hits.select(1, 1).to(at::kDouble) + 0.5;
  int64_t matched = 0;
  for (const auto& [u, v] : expected) {
    auto d = at::maximum((hit_cols - u).abs(), (hit_rows - v).abs());
    matched += d.min().item<double>() <= 1.0;
  }
  EXPECT_EQ(matched, static_cast<int64_t>(expected.size()));
  // Samples lie on the scan lines: elevation within half a pixel (≈ 0.36°) of a beam.
  auto sampled_rays = rays.rays.index({hits.select(1, 0), hits.select(1, 1)});
  auto el_deg = at::asin(-sampled_rays.select(1, 1)) * (180 / M_PI);
  auto off = (el_deg + 15.0) / 2.0;
  EXPECT_LT(((off - off.round()) * 2.0).abs().max().item<double>(), 0.4);
  EXPECT_TRUE(s.depth.masked_select(s.valid).eq(5.0).all().item<bool>());
  // Batched maps with shared rays: per-item validity is respected.
  auto batch_valid = rays.valid.unsqueeze(0).repeat({2, 1, 1});
  batch_valid[1].slice(1, 0, w / 2).fill_(false);
  auto batched =
      sample_lidar(depth.unsqueeze(0).expand({2, h, w}), batch_valid, rays.rays, pattern);
  EXPECT_TRUE(at::equal(batched.valid[0], s.valid));
  EXPECT_FALSE(batched.valid[1].slice(1, 0, w / 2).any().item<bool>());
  EXPECT_TRUE(at::equal(batched.valid[1].slice(1, w / 2), s.valid.slice(1, w / 2)));
  EXPECT_THROW(sample_lidar(depth, rays.valid, rays.rays, LidarPattern{0, -1.0, 1.0, 10}),
               std::invalid_argument);
}

TEST(SparseSampling, PointsThroughACameraLandOnTheirPixels) {
  const int64_t w = 64, h = 48;
  auto camera = make_camera("PINHOLE", w, h, {50.0, 55.0, 31.0, 25.0});
  auto g = seeded(10);
  auto points = at::rand({300, 3}, g, at::kDouble) * at::tensor({8.0, 6.0, 10.0}, at::kDouble) -
                at::tensor({4.0, 3.0, 2.0}, at::kDouble);  // some behind the camera (z < 0)
  auto s = sparse_depth_from_points(points, camera);
  int64_t landed = 0;
  auto expected = at::zeros({h, w}, at::kDouble);
  for (int64_t i = 0; i < 300; ++i) {
    const double x = points[i][0].item<double>(), y = points[i][1].item<double>(),
                 z = points[i][2].item<double>();
    if (z <= 0) continue;
    const double u = 50.0 * x / z + 31.0, v = 55.0 * y / z + 25.0;
    if (u < 0 || u >= w || v < 0 || v >= h) continue;
    const double d = std::sqrt(x * x + y * y + z * z);
    auto cell = expected[static_cast<int64_t>(v)][static_cast<int64_t>(u)];
    if (cell.item<double>() == 0 || d < cell.item<double>()) cell.fill_(d);
    ++landed;
  }
  ASSERT_GT(landed, 20);
  EXPECT_TRUE(at::equal(s.valid, expected > 0));
  EXPECT_TRUE(at::allclose(s.depth, expected, 1e-12, 1e-12));
  auto planar = sparse_depth_from_points(points, camera, {}, SparseValue::PlanarDepth);
  EXPECT_TRUE(at::equal(planar.valid, s.valid));
  EXPECT_TRUE((planar.depth <= s.depth + 1e-12).all().item<bool>());
}

TEST(SparseSampling, ZBufferKeepsTheNearest) {
  auto camera = make_camera("PINHOLE", 10, 10, {10.0, 10.0, 5.0, 5.0});
  // Three points on one ray, far first; a padded batch where the nearest is masked out.
  auto ray = at::tensor({0.1, 0.05, 1.0}, at::kFloat);
  auto points = at::stack({ray * 9.0f, ray * 3.0f, ray * 6.0f}).unsqueeze(0).repeat({2, 1, 1});
  auto valid = at::ones({2, 3}, at::kBool);
  valid[1][1] = false;
  auto s = sparse_depth_from_points(points, camera, valid);
  ASSERT_EQ(s.depth.sizes(), (at::IntArrayRef{2, 10, 10}));
  EXPECT_EQ(s.valid.sum().item<int64_t>(), 2);
  // (x, y) = (10·0.1 + 5, 10·0.05 + 5) = (6, 5.5): pixel column 6, row 5.
  const float norm = ray.norm().item<float>();
  EXPECT_FLOAT_EQ(s.depth[0][5][6].item<float>(), 3.0f * norm);
  EXPECT_FLOAT_EQ(s.depth[1][5][6].item<float>(), 6.0f * norm);
  // rasterize_nearest directly: ties keep the smallest value; off-image pixels are dropped.
  auto pixels = at::tensor({0.5, 0.5, 0.7, 0.2, 2.0, 0.5, -0.1, 0.5}, at::kDouble).view({4, 2});
  auto r = rasterize_nearest(pixels, at::tensor({2.0, 2.0, 1.0, 1.0}, at::kDouble),
                             at::tensor({7.0, 4.0, 1.0, 1.0}, at::kDouble),
                             at::ones({4}, at::kBool), 2, 1);
  EXPECT_TRUE(at::equal(r.depth, at::tensor({4.0, 0.0}, at::kDouble).view({1, 2})));
  EXPECT_TRUE(at::equal(r.valid, at::tensor({1, 0}).to(at::kBool).view({1, 2})));
}

TEST(SparseSampling, PointsBehindTheCameraLandInAPanorama) {
  // An equirectangular camera sees all around: a point behind the camera (z < 0) lands at
  // azimuth 180° (x = W · (θ / 2π + 0.5)), elevation from -y.
  const int64_t w = 360, h = 180;
  auto camera = make_camera("EQUIRECTANGULAR", w, h, {});
  auto points =
      at::tensor({0.0, 0.0, -4.0, 2.0, -2.0, 0.0, 0.0, 0.0, 3.0}, at::kDouble).view({3, 3});
  auto s = sparse_depth_from_points(points, camera);
  EXPECT_EQ(s.valid.sum().item<int64_t>(), 3);
  // (0, 0, -4): θ = π -> x = 360 (the seam, wraps to column 0 or 359), φ = 0 -> row 90.
  EXPECT_EQ(s.valid[90][0].item<bool>() || s.valid[90][359].item<bool>(), true);
  // (2, -2, 0): θ = 90° -> column 270; φ = 45° up -> row 45.
  EXPECT_NEAR(s.depth[45][270].item<double>(), std::sqrt(8.0), 1e-9);
  // (0, 0, 3): straight ahead -> column 180, row 90.
  EXPECT_DOUBLE_EQ(s.depth[90][180].item<double>(), 3.0);
  auto planar = sparse_depth_from_points(points, camera, {}, SparseValue::PlanarDepth);
  EXPECT_DOUBLE_EQ(planar.depth.masked_select(planar.valid).min().item<double>(), -4.0);
}

TEST(SparseSampling, LidarAllAroundInAPanorama) {
  // 1° per pixel; beams at -9.5°, 0.5°, 10.5° hit the pixel rows 99, 89, 79 (centres at
  // elevation 90° - row - 0.5); 90 firings per revolution each, behind the camera included.
  const int64_t w = 360, h = 180;
  auto camera = make_camera("EQUIRECTANGULAR", w, h, {});
  auto rays = camera.ray_map(at::kDouble);
  auto s = sample_lidar(at::full({h, w}, 2.0, at::kDouble), rays.valid, rays.rays,
                        LidarPattern{3, -9.5, 10.5, 90});
  EXPECT_EQ(s.valid.sum().item<int64_t>(), 270);
  for (int64_t row : {79, 89, 99}) EXPECT_EQ(s.valid[row].sum().item<int64_t>(), 90) << row;
}

// Shrinking a sparse map keeps every sample that has a pixel of its own at the new size, and
// where several meet, the nearest; nothing is blended.
TEST(SparseSampling, ResizedSparseMapKeepsSamplesAndTheNearest) {
  at::Tensor map = at::zeros({8, 8}, at::kFloat);
  map[0][0] = 5.0;  // alone in the top-left 4x4 block
  map[1][6] = 3.0;  // the top-right block holds two: the nearer, 2, wins
  map[2][5] = 2.0;
  map[7][7] = std::nanf("");  // not a sample
  map[6][1] = -1.0;           // not a sample
  const at::Tensor small = resize_sparse_map(map, 2, 2);
  EXPECT_TRUE(at::equal(small, at::tensor({5.0f, 2.0f, 0.0f, 0.0f}).view({2, 2}))) << small;
  // Growing moves each sample to the pixel holding its centre: (x + 0.5) * 3 -> 1.5 -> 1.
  const at::Tensor large = resize_sparse_map(map, 24, 24);
  EXPECT_EQ((large > 0).sum().item<int64_t>(), 3);
  EXPECT_EQ(large[1][1].item<float>(), 5.0f);
  EXPECT_EQ(large[4][19].item<float>(), 3.0f);
  EXPECT_THROW(resize_sparse_map(at::zeros({8}), 2, 2), std::invalid_argument);
}

// A sweep taken beside the camera (kSensorSweep): a box in front of a wall, a LiDAR 0.6 m right
// of and 0.3 m above the camera firing a grid coarser than the pixels. Returns from the wall
// that the box hides from the camera land on the box's image, often in pixels without a box
// return (the plain z-buffer keeps them there); the sweep rule keeps none of them, and every
// sample it keeps is the distance of a surface point the camera sees, exactly.
namespace {

struct BoxAndWall {
  double wall_z = 4.0;
  // Both centres lie within the box's x and y extents: both see its front face only.
  double lo[3] = {-0.4, -0.4, 1.8}, hi[3] = {0.8, 0.4, 2.2};
  // The first hit of the ray origin + t · direction (t > 0), +inf without one.
  double first_hit(const double* origin, const double* direction) const {
    double t_near = -std::numeric_limits<double>::infinity();
    double t_far = std::numeric_limits<double>::infinity();
    for (int axis = 0; axis < 3; ++axis) {
      const double a = (lo[axis] - origin[axis]) / direction[axis];
      const double b = (hi[axis] - origin[axis]) / direction[axis];
      t_near = std::max(t_near, std::min(a, b));
      t_far = std::min(t_far, std::max(a, b));
    }
    const double wall = direction[2] > 0 ? (wall_z - origin[2]) / direction[2]
                                         : std::numeric_limits<double>::infinity();
    return t_near <= t_far && t_near > 0 ? std::min(t_near, wall) : wall;
  }
};

}  // namespace

TEST(SparseSampling, SweepFromBesideTheCameraKeepsOnlyWhatTheCameraSees) {
  const int64_t w = 40, h = 30;
  auto camera = make_camera("PINHOLE", w, h, {30.0, 30.0, 20.0, 15.0});
  const BoxAndWall scene;
  const double lidar[3] = {0.6, -0.3, 0.0};
  std::vector<double> xyz;
  for (double azimuth = -0.7; azimuth <= 0.7; azimuth += 0.05)
    for (double elevation = -0.55; elevation <= 0.55; elevation += 0.05) {
      const double d[3] = {std::sin(azimuth) * std::cos(elevation), std::sin(elevation),
                           std::cos(azimuth) * std::cos(elevation)};
      const double t = scene.first_hit(lidar, d);
      for (int k = 0; k < 3; ++k) xyz.push_back(lidar[k] + t * d[k]);
    }
  const int64_t n = static_cast<int64_t>(xyz.size()) / 3;
  const at::Tensor points = at::tensor(xyz, at::kDouble).view({n, 3});
  // What the camera sees along each return's own ray.
  std::vector<double> seen(n);
  const double origin[3] = {0, 0, 0};
  for (int64_t i = 0; i < n; ++i) {
    const double* p = xyz.data() + 3 * i;
    const double range = std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
    const double d[3] = {p[0] / range, p[1] / range, p[2] / range};
    seen[i] = scene.first_hit(origin, d);
  }
  const at::Tensor range = points.norm(2, -1);
  const at::Tensor visible = at::tensor(seen, at::kDouble) >= range * (1 - 1e-9);
  const omnipoint::camera::Pixels projected = camera.project(points);
  const at::Tensor cell = projected.pixels.floor().to(at::kLong);
  const at::Tensor in_image = projected.valid & (cell.select(1, 0) >= 0) & (cell.select(1, 0) < w) &
                              (cell.select(1, 1) >= 0) & (cell.select(1, 1) < h);
  ASSERT_GT((in_image & ~visible).sum().item<int64_t>(), 20);  // hidden returns in the image

  // Each sample's return: the one in its pixel with its value.
  const auto hidden_samples = [&](const SparseDepth& s, int64_t* checked) {
    int64_t hidden = 0;
    for (int64_t i = 0; i < n; ++i) {
      if (!in_image[i].item<bool>()) continue;
      const int64_t x = cell[i][0].item<int64_t>(), y = cell[i][1].item<int64_t>();
      const double r = range[i].item<double>();
      if (!s.valid[y][x].item<bool>() || std::abs(s.depth[y][x].item<double>() - r) > 1e-12 * r)
        continue;
      if (checked) {
        EXPECT_NEAR(s.depth[y][x].item<double>() / seen[i], 1.0, 1e-5) << x << ", " << y;
        ++*checked;
      }
      if (!visible[i].item<bool>()) ++hidden;
    }
    return hidden;
  };
  // The plain z-buffer keeps hidden returns.
  EXPECT_GT(hidden_samples(sparse_depth_from_points(points, camera), nullptr), 5);
  const SparseDepth sweep = sparse_depth_from_points(points, camera, {}, SparseValue::Distance,
                                                     PointSelection::kSensorSweep);
  int64_t checked = 0;
  EXPECT_EQ(hidden_samples(sweep, &checked), 0);
  EXPECT_EQ(checked, sweep.valid.sum().item<int64_t>());
  // Every pixel holding a box return the camera sees keeps a sample.
  const at::Tensor on_box = in_image & visible & (range < 3.0);
  ASSERT_GT(on_box.sum().item<int64_t>(), 20);
  for (int64_t i = 0; i < n; ++i) {
    if (!on_box[i].item<bool>()) continue;
    EXPECT_TRUE(sweep.valid[cell[i][1].item<int64_t>()][cell[i][0].item<int64_t>()].item<bool>());
  }
  // Planar depth: the same samples.
  const SparseDepth planar = sparse_depth_from_points(points, camera, {}, SparseValue::PlanarDepth,
                                                      PointSelection::kSensorSweep);
  EXPECT_TRUE(at::equal(planar.valid, sweep.valid));
}

// Within a pixel, the sweep rule keeps the return nearest to the pixel centre, where the
// prediction it is compared with is sampled; the z-buffer keeps the nearest to the camera.
TEST(SparseSampling, SweepKeepsTheReturnNearestThePixelCentre) {
  auto camera = make_camera("PINHOLE", 10, 10, {10.0, 10.0, 5.0, 5.0});
  // Pixel (6, 5) spans x in [6, 7), y in [5, 6): its centre is (6.5, 5.5). A slanted surface:
  // 3.0 m at its corner (6.1, 5.1), 3.2 m near its centre (6.45, 5.55).
  const auto at_pixel = [](double x, double y, double distance) {
    const at::Tensor ray = at::tensor({(x - 5.0) / 10.0, (y - 5.0) / 10.0, 1.0}, at::kDouble);
    return ray / ray.norm() * distance;
  };
  const at::Tensor points = at::stack({at_pixel(6.1, 5.1, 3.0), at_pixel(6.45, 5.55, 3.2)});
  EXPECT_DOUBLE_EQ(sparse_depth_from_points(points, camera).depth[5][6].item<double>(), 3.0);
  const SparseDepth sweep = sparse_depth_from_points(points, camera, {}, SparseValue::Distance,
                                                     PointSelection::kSensorSweep);
  EXPECT_EQ(sweep.valid.sum().item<int64_t>(), 1);
  EXPECT_NEAR(sweep.depth[5][6].item<double>(), 3.2, 1e-12);
  // With the pixel as the window (one other return suffices), a return clearly behind (4.0 m:
  // 25 % > the 10 % margin) is hidden, even at the centre; a batch of two keeps the items apart.
  SweepOcclusion pixel_window;
  pixel_window.min_neighbours = 1;
  const at::Tensor behind = at::stack({at_pixel(6.1, 5.1, 3.0), at_pixel(6.5, 5.5, 4.0)});
  const SparseDepth two =
      sparse_depth_from_points(at::stack({points, behind}), camera, {}, SparseValue::Distance,
                               PointSelection::kSensorSweep, pixel_window);
  EXPECT_NEAR(two.depth[0][5][6].item<double>(), 3.2, 1e-12);
  EXPECT_NEAR(two.depth[1][5][6].item<double>(), 3.0, 1e-12);
  SweepOcclusion bad;
  bad.occlusion_margin = 0;
  EXPECT_THROW(sparse_depth_from_points(points, camera, {}, SparseValue::Distance,
                                        PointSelection::kSensorSweep, bad),
               std::invalid_argument);
}
