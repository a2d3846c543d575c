// The ray caster against closed forms: spheres, planes, boxes and cylinders around the
// camera, through every camera model of the zoo.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>

#include "camera/sample_cameras.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/render.h"
#include "omnipoint/data/synth/scene.h"

namespace omnipoint::data::synth {
namespace {

// A scene with one grey material and no lights (ambient only), camera at `eye`.
Scene bare_scene(const Vec3& eye, double yaw = 0.3, double pitch = -0.2, double roll = 0.1) {
  Scene scene;
  scene.materials.push_back(Material{});
  scene.pose = make_pose(eye, yaw, pitch, roll);
  return scene;
}

Primitive sphere(const Vec3& c, double r) {
  Primitive p;
  p.shape = Shape::kSphere;
  p.center = c;
  p.radius = r;
  return p;
}

camera::Camera small(const std::string& spec) {
  const auto cam = camera::parse_camera(spec);
  return cam.resized(std::max<int64_t>(cam.width() / 4, 8), std::max<int64_t>(cam.height() / 4, 8));
}

TEST(SynthRender, SphereAroundTheCameraIsAtItsRadiusForEveryModel) {
  const double radius = 3.25;
  auto scene = bare_scene({1.0, -2.0, 1.5});
  scene.primitives.push_back(sphere({1.0, -2.0, 1.5}, radius));
  for (const auto& spec : camera::testing::sample_camera_specs()) {
    SCOPED_TRACE(spec);
    const auto cam = small(spec);
    const auto rays = cam.ray_map(at::kDouble);
    const auto out = render_scene(scene, rays.rays, rays.valid);
    EXPECT_TRUE(at::equal(out.mask, rays.valid));
    const auto d = out.distance.masked_select(rays.valid);
    ASSERT_GT(d.numel(), 0);
    EXPECT_LT((d - radius).abs().max().item<double>(), 1e-9);
    EXPECT_EQ(out.distance.masked_select(rays.valid.logical_not()).abs().sum().item<double>(), 0.0);
    // Normals of a sphere seen from its centre point straight back along the rays.
    const auto n = out.normals.index({rays.valid});
    EXPECT_LT((n + rays.rays.index({rays.valid})).abs().max().item<double>(), 1e-9);
  }
}

TEST(SynthRender, SphereRadiusHoldsInFloat32) {
  auto scene = bare_scene({0, 0, 0});
  scene.primitives.push_back(sphere({0, 0, 0}, 7.0));
  const auto rays = camera::parse_camera("EQUIRECTANGULAR 64 32").ray_map(at::kFloat);
  const auto out = render_scene(scene, rays.rays, rays.valid);
  EXPECT_TRUE(out.mask.all().item<bool>());
  EXPECT_LT((out.distance - 7.0).abs().max().item<double>(), 1e-5);
}

TEST(SynthRender, PlaneAheadGivesConstantPlanarDepthThroughAPinhole) {
  // Level camera looking north (+y) at the plane y = eye.y + c.
  const double c = 4.5;
  auto scene = bare_scene({0.5, 1.0, 1.6}, 0.0, 0.0, 0.0);
  Primitive plane;
  plane.shape = Shape::kPlane;
  plane.center = {0, 1.0 + c, 0};
  plane.axis = {0, -1, 0};
  scene.primitives.push_back(plane);
  const auto cam = camera::parse_camera("PINHOLE 80 60 70 72 41 29.5");
  const auto rays = cam.ray_map(at::kDouble);
  const auto out = render_scene(scene, rays.rays, rays.valid);
  ASSERT_TRUE(out.mask.all().item<bool>());
  EXPECT_LT((out.depth - c).abs().max().item<double>(), 1e-9);
  EXPECT_LT((out.distance * rays.rays.select(-1, 2) - c).abs().max().item<double>(), 1e-9);
  // The plane faces the camera: its normal is -z in the camera frame.
  EXPECT_LT((out.normals - at::tensor({0.0, 0.0, -1.0}, at::kDouble)).abs().max().item<double>(),
            1e-12);
}

TEST(SynthRender, RoomBoxCylinderAndOpening) {
  const Vec3 eye{0, 0, 1.5};
  auto scene = bare_scene(eye, 0.0, 0.0, 0.0);
  Primitive room;  // a cube room around the camera, 2 m to each wall
  room.shape = Shape::kBox;
  room.center = eye;
  room.half_size = {2, 2, 2};
  scene.primitives.push_back(room);
  const auto cam = camera::parse_camera("PINHOLE 9 9 8 8 4.5 4.5");
  auto rays = cam.ray_map(at::kDouble);
  auto out = render_scene(scene, rays.rays, rays.valid);
  EXPECT_NEAR(out.distance[4][4].item<double>(), 2.0, 1e-12);
  EXPECT_TRUE(out.mask.all().item<bool>());

  // A window in the north wall (+y, the view direction) around the optical axis: sky.
  scene.primitives[0].openings.push_back(Opening{1, 1, {-0.5, -0.5}, {0.5, 0.5}});
  out = render_scene(scene, rays.rays, rays.valid);
  EXPECT_FALSE(out.mask[4][4].item<bool>());
  EXPECT_EQ(out.distance[4][4].item<double>(), 0.0);
  EXPECT_TRUE(out.mask[0][0].item<bool>());

  // A vertical pillar of radius 0.25 centred 1.25 m ahead: 1 m away on the axis.
  Primitive pillar;
  pillar.shape = Shape::kCylinder;
  pillar.center = {0, 1.25, 1.5};
  pillar.axis = {0, 0, 1};
  pillar.radius = 0.25;
  pillar.half_size = {0.25, 0.25, 1.5};
  scene.primitives.push_back(pillar);
  out = render_scene(scene, rays.rays, rays.valid);
  EXPECT_NEAR(out.distance[4][4].item<double>(), 1.0, 1e-12);
  EXPECT_LT(
      (out.normals[4][4] - at::tensor({0.0, 0.0, -1.0}, at::kDouble)).abs().max().item<double>(),
      1e-12);
}

TEST(SynthRender, CameraInsideAVerticalCylinderSeesItsWallAndCaps) {
  const double r = 1.5, half = 2.0;
  auto scene = bare_scene({0, 0, 0}, 0.7, 0.0, 0.0);
  Primitive tube;
  tube.shape = Shape::kCylinder;
  tube.axis = {0, 0, 1};
  tube.radius = r;
  tube.half_size = {r, r, half};
  scene.primitives.push_back(tube);
  const auto rays = camera::parse_camera("EQUIRECTANGULAR 64 32").ray_map(at::kDouble);
  const auto out = render_scene(scene, rays.rays, rays.valid);
  ASSERT_TRUE(out.mask.all().item<bool>());
  // Elevation phi of each pixel (up positive, camera level): -ray.y = sin(phi).
  const auto sin_phi = -rays.rays.select(-1, 1), cos_phi = at::sqrt(1 - sin_phi * sin_phi);
  const auto expected =
      at::where(sin_phi.abs() * r > half * cos_phi, half / sin_phi.abs(), r / cos_phi);
  EXPECT_LT((out.distance - expected).abs().max().item<double>(), 1e-9);
}

TEST(SynthRender, HitsBeyondTheMaximumDistanceAreSky) {
  auto scene = bare_scene({0, 0, 0}, 0.0, 0.0, 0.0);
  Primitive plane;  // 2 km ahead
  plane.shape = Shape::kPlane;
  plane.center = {0, 2000, 0};
  plane.axis = {0, -1, 0};
  scene.primitives.push_back(plane);
  const auto rays = camera::parse_camera("PINHOLE 8 6 10 10 4 3").ray_map(at::kDouble);
  EXPECT_FALSE(render_scene(scene, rays.rays, rays.valid).mask.any().item<bool>());
  RenderOptions far;
  far.max_distance = 5000;
  const auto out = render_scene(scene, rays.rays, rays.valid, far);
  EXPECT_TRUE(out.mask.all().item<bool>());
  EXPECT_LT((out.depth - 2000).abs().max().item<double>(), 1e-9);
}

TEST(SynthRender, RejectsBadInputs) {
  auto scene = bare_scene({0, 0, 0});
  const auto rays = at::zeros({4, 4, 3});
  EXPECT_THROW(render_scene(scene, rays, at::ones({4, 4})), std::invalid_argument);
  EXPECT_THROW(render_scene(scene, at::zeros({4, 4}), at::ones({4, 4}, at::kBool)),
               std::invalid_argument);
  Scene empty;
  EXPECT_THROW(render_scene(empty, rays, at::ones({4, 4}, at::kBool)), std::invalid_argument);
}

}  // namespace
}  // namespace omnipoint::data::synth
