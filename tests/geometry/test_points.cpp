#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>

#include "omnipoint/geometry/points.h"

using namespace omnipoint::geometry;

namespace {

// Unit rays of a pinhole camera at pixel centres, (H, W, 3), and the rays' K⁻¹[u, v, 1].
at::Tensor pinhole_directions(int64_t h, int64_t w, double f, at::ScalarType dtype) {
  auto opts = at::TensorOptions().dtype(dtype);
  auto u = (at::arange(w, opts) + 0.5 - w / 2.0) / f;
  auto v = (at::arange(h, opts) + 0.5 - h / 2.0) / f;
  auto grid = at::meshgrid({v, u}, "ij");
  return at::stack({grid[1], grid[0], at::ones({h, w}, opts)}, -1);
}

at::Tensor unit(const at::Tensor& v) {
  return v / v.norm(2, -1, true);
}

}  // namespace

TEST(Points, RaysDistanceRoundTrip) {
  auto g = at::make_generator<at::CPUGeneratorImpl>(1);
  for (auto dtype : {at::kFloat, at::kDouble}) {
    auto rays = unit(at::randn({2, 5, 7, 3}, g, dtype));
    auto distance = at::rand({2, 5, 7}, g, dtype) * 10 + 0.1;
    auto points = points_from_rays(rays, distance);
    EXPECT_EQ(points.scalar_type(), dtype);
    auto back = rays_from_points(points);
    const double tol = dtype == at::kFloat ? 1e-5 : 1e-12;
    EXPECT_TRUE(at::allclose(back.rays, rays, tol, tol));
    EXPECT_TRUE(at::allclose(back.distance, distance, tol, tol));
    EXPECT_TRUE(back.valid.all().item<bool>());
  }
}

TEST(Points, ZeroAndNonFinitePointsAreInvalidWithoutNaN) {
  auto points =
      at::tensor({0.0, 0.0, 0.0, NAN, 1.0, 1.0, INFINITY, 0.0, 0.0, 0.0, 0.0, -2.0}).view({4, 3});
  auto r = rays_from_points(points);
  EXPECT_FALSE(r.valid[0].item<bool>());
  EXPECT_FALSE(r.valid[1].item<bool>());
  EXPECT_FALSE(r.valid[2].item<bool>());
  EXPECT_TRUE(r.valid[3].item<bool>());
  EXPECT_TRUE(at::isfinite(r.rays).all().item<bool>());
  EXPECT_TRUE(r.rays.slice(0, 0, 3).eq(0).all().item<bool>());
  EXPECT_TRUE(r.distance.slice(0, 0, 3).eq(0).all().item<bool>());
  // A point behind the camera: a valid backward ray, distance 2, planar depth -2.
  EXPECT_TRUE(at::equal(r.rays[3], at::tensor({0.0, 0.0, -1.0})));
  EXPECT_DOUBLE_EQ(r.distance[3].item<double>(), 2.0);
  EXPECT_DOUBLE_EQ(planar_depth(points)[3].item<double>(), -2.0);
}

TEST(Points, PinholeDepthDistanceClosedForm) {
  const int64_t h = 6, w = 8;
  const double f = 5.0;
  auto dirs = pinhole_directions(h, w, f, at::kDouble);
  auto rays = unit(dirs);
  auto depth = at::linspace(0.5, 9.0, h * w, at::kDouble).view({h, w});
  auto result = distance_from_planar_depth(depth, rays);
  EXPECT_TRUE(result.valid.all().item<bool>());
  // d = z · |K⁻¹[u, v, 1]| for a pinhole camera.
  EXPECT_TRUE(at::allclose(result.distance, depth * dirs.norm(2, -1), 1e-12, 1e-12));
  // Back to planar depth through the points.
  EXPECT_TRUE(
      at::allclose(planar_depth(points_from_rays(rays, result.distance)), depth, 1e-12, 1e-12));
}

TEST(Points, DistanceFromDepthRejectsSidewaysAndBackwardRays) {
  auto rays =
      at::tensor({1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0}).view({4, 3});
  auto depth = at::tensor({2.0, -2.0, -1.0, 3.0});
  auto result = distance_from_planar_depth(depth, rays);
  EXPECT_TRUE(at::equal(result.valid, at::tensor({0, 0, 0, 1}).to(at::kBool)));
  EXPECT_TRUE(at::equal(result.distance, at::tensor({0.0, 0.0, 0.0, 3.0})));
}

TEST(Points, PlaneNormalsFaceTheCamera) {
  // The plane n · P = c seen through a pinhole camera; its normal towards the camera is -n.
  const int64_t h = 20, w = 30;
  auto dirs = pinhole_directions(h, w, 25.0, at::kDouble);
  auto n = unit(at::tensor({0.3, -0.2, 1.0}, at::kDouble));
  const double c = 4.0;
  auto t = c / (dirs * n).sum(-1);
  auto points = dirs * t.unsqueeze(-1);
  auto normals = normals_from_point_map(points);
  EXPECT_TRUE(normals.valid.all().item<bool>());
  EXPECT_LT((normals.normals + n).abs().max().item<double>(), 1e-12);
  // Batched float32 gives the same answer.
  auto batched = normals_from_point_map(points.to(at::kFloat).unsqueeze(0).expand({2, h, w, 3}));
  EXPECT_LT((batched.normals.to(at::kDouble) + n).abs().max().item<double>(), 1e-5);
}

TEST(Points, SphereNormalsAndBehindTheCamera) {
  // The inside of a sphere of radius 3 around the camera: every normal points at the
  // camera, n = -P / |P|, also for the rays behind the camera (z < 0) of a panorama.
  const int64_t h = 90, w = 180;
  auto opts = at::TensorOptions().dtype(at::kDouble);
  auto lon = (at::arange(w, opts) + 0.5) / w * 2 * M_PI - M_PI;
  auto lat = M_PI / 2 - (at::arange(h, opts) + 0.5) / h * M_PI;
  auto grid = at::meshgrid({lat, lon}, "ij");
  auto rays =
      at::stack({grid[0].cos() * grid[1].sin(), -grid[0].sin(), grid[0].cos() * grid[1].cos()}, -1);
  auto points = rays * 3.0;
  auto normals = normals_from_point_map(points);
  EXPECT_TRUE(normals.valid.all().item<bool>());
  auto cosine = -(normals.normals * rays).sum(-1);
  // Away from the poles (where the grid degenerates) and the seam (one-sided
  // differences), within the discretisation error.
  auto band = cosine.slice(0, 5, h - 5).slice(1, 1, w - 1);
  EXPECT_GT(band.min().item<double>(), std::cos(1e-6));
  EXPECT_TRUE((planar_depth(points) < 0).any().item<bool>());
  // The outside of a sphere in front of a pinhole camera: n = (P - C) / R.
  auto dirs = pinhole_directions(40, 40, 60.0, at::kDouble);
  auto ray = unit(dirs);
  const double cz = 10.0, radius = 4.0;
  auto b = ray.select(-1, 2) * cz;
  auto t = b - (b * b - (cz * cz - radius * radius)).sqrt();
  auto p = ray * t.unsqueeze(-1);
  auto expected = (p - at::tensor({0.0, 0.0, cz}, opts)) / radius;
  auto hit = at::isfinite(t);
  ASSERT_TRUE(hit.logical_not().any().item<bool>());
  auto sphere = normals_from_point_map(p);
  EXPECT_TRUE(at::equal(sphere.valid, hit));
  // Pixels whose four neighbours hit the sphere too (no one-sided differences).
  auto hit4 = hit.slice(0, 1, -1).slice(1, 1, -1) & hit.slice(0, 0, -2).slice(1, 1, -1) &
              hit.slice(0, 2).slice(1, 1, -1) & hit.slice(0, 1, -1).slice(1, 0, -2) &
              hit.slice(0, 1, -1).slice(1, 2);
  auto cos_err =
      (sphere.normals * expected).sum(-1).slice(0, 1, -1).slice(1, 1, -1).masked_select(hit4);
  // Largest error (8e-3 rad) next to the grazing silhouette, where curvature per pixel peaks.
  EXPECT_GT(cos_err.min().item<double>(), std::cos(0.01));
}

TEST(Points, NormalValidityFollowsNeighbours) {
  auto dirs = pinhole_directions(5, 5, 4.0, at::kDouble);
  auto mask = at::ones({5, 5}, at::kBool);
  // An isolated valid pixel: no valid neighbour pair, so no normal.
  mask.slice(0, 0, 3).slice(1, 0, 3).fill_(false);
  mask[1][1] = true;
  auto normals = normals_from_point_map(dirs * 2.0, mask);
  EXPECT_FALSE(normals.valid[1][1].item<bool>());
  EXPECT_FALSE(normals.valid[0][0].item<bool>());
  EXPECT_TRUE(normals.valid[4][4].item<bool>());
  EXPECT_TRUE(normals.normals[1][1].eq(0).all().item<bool>());
  // A NaN point only invalidates itself and the pairs that use it.
  auto p = dirs * 2.0;
  p[2][2][0] = NAN;
  auto with_nan = normals_from_point_map(p);
  EXPECT_FALSE(with_nan.valid[2][2].item<bool>());
  EXPECT_TRUE(with_nan.valid[2][1].item<bool>());
  EXPECT_TRUE(at::isfinite(with_nan.normals).all().item<bool>());
}

TEST(Points, PointCloudFromPointMap) {
  auto points = at::arange(2 * 3 * 3, at::kFloat).view({2, 3, 3}) + 1;
  auto image = at::tensor({0.0f, 0.5f, 1.0f, 1.2f, -0.1f, 0.25f})
                   .view({2, 1, 3})
                   .expand({2, 3, 3})
                   .contiguous();
  auto mask = at::tensor({1, 0, 1, 1, 1, 0}).to(at::kBool).view({2, 3});
  points[1][0][1] = NAN;
  auto cloud = make_point_cloud(points, image, mask);
  ASSERT_EQ(cloud.points.sizes(), (at::IntArrayRef{6, 3}));
  EXPECT_EQ(cloud.colors.scalar_type(), at::kByte);
  EXPECT_TRUE(at::equal(cloud.valid, at::tensor({1, 0, 1, 0, 1, 0}).to(at::kBool)));
  auto kept = valid_points(cloud);
  ASSERT_EQ(kept.points.size(0), 3);
  EXPECT_TRUE(at::equal(kept.points[1], points[0][2]));
  EXPECT_TRUE(at::equal(kept.colors[0], at::tensor({0, 128, 255}, at::kByte)));
  EXPECT_TRUE(at::equal(kept.colors[2], at::tensor({255, 0, 64}, at::kByte)));
  EXPECT_THROW(make_point_cloud(points, image.slice(0, 0, 1), mask), std::invalid_argument);
  EXPECT_THROW(valid_points(make_point_cloud(points.unsqueeze(0), image.unsqueeze(0))),
               std::invalid_argument);
}

TEST(Points, ValidPointsOfAWhollyValidCloudKeepsEveryPointInOrder) {
  const auto points = at::rand({4, 5, 3}) + 1;
  const auto image = at::rand({4, 5, 3});
  const auto cloud = make_point_cloud(points, image);
  const auto kept = valid_points(cloud);
  EXPECT_TRUE(at::equal(kept.points, points.reshape({20, 3})));
  EXPECT_TRUE(at::equal(kept.colors, cloud.colors));
  ASSERT_EQ(kept.valid.size(0), 20);
  EXPECT_TRUE(kept.valid.all().item<bool>());
}
