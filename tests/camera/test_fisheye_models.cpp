// The fisheye and unified models beyond the typed tests: circular fisheyes whose limit (a
// fold or the domain's edge) lies inside the image, rays behind the image plane, the lens
// limits themselves (from independent closed forms), identities between models, and the
// parameter rules.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/equidistant_fisheye.h"

namespace omnipoint::camera {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Unit rays (N, 3) at angles `thetas` from the axis, azimuth phi (from +x towards +y).
at::Tensor rays_at(const std::vector<double>& thetas, double phi) {
  std::vector<double> values;
  for (const double theta : thetas) {
    values.insert(values.end(), {std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi),
                                 std::cos(theta)});
  }
  return at::tensor(values, at::kDouble).view({-1, 3});
}

at::Tensor random_directions(int64_t count) {
  at::manual_seed(11);
  const auto directions = at::randn({count, 3}, at::kDouble);
  return directions / directions.norm(2, -1, true);
}

double max_where(const at::Tensor& valid, const at::Tensor& values) {
  return at::where(valid, values, at::zeros_like(values)).max().item<double>();
}

// A circular fisheye over 180 degrees and its limit angle, from a closed form written here
// independently of the model code.
struct WideCamera {
  std::string spec;
  std::function<double(const std::vector<double>&)> limit_angle;
};

double kannala_brandt_slope(double theta, const std::vector<double>& k) {
  double slope = 1.0;
  for (std::size_t i = 0; i < k.size(); ++i)
    slope += (2.0 * i + 3.0) * k[i] * std::pow(theta, 2.0 * i + 2.0);
  return slope;
}

double unified_w(double alpha) {
  return alpha <= 0.5 ? alpha / (1 - alpha) : (1 - alpha) / alpha;
}

const std::vector<WideCamera>& wide_cameras() {
  static const std::vector<WideCamera> cameras = {
      // θ_d(θ) peaks at 125 degrees: the first root of 1 + 3 k1 θ² + ... + 9 k4 θ⁸.
      {"OPENCV_FISHEYE 640 480 183.7 184.2 319.3 241.6 0.0342 -0.0147 0.0021 -0.0003",
       [](const std::vector<double>& p) {
         double low = 0.5, high = kPi;  // the slope is positive at 0.5 and negative at π
         for (int i = 0; i < 200; ++i) {
           const double mid = 0.5 * (low + high);
           (kannala_brandt_slope(mid, {p[4], p[5], p[6], p[7]}) > 0 ? low : high) = mid;
         }
         return low;
       }},
      // ξ > 1: the fold at cos θ = −1 / ξ (138 degrees).
      {"MEI 640 480 205.0 204.3 321.4 238.7 1.35 -0.12 0.05 0.0006 -0.0004",
       [](const std::vector<double>& p) { return std::acos(-1.0 / p[4]); }},
      // α > 0.5: the fold at cos θ = −(1 − α) / α (128 degrees).
      {"UCM 640 480 161.3 160.8 318.6 242.3 0.62",
       [](const std::vector<double>& p) { return std::acos(-unified_w(p[4])); }},
      // cos θ = −w sqrt(β sin² θ + cos² θ)  <=>  tan² θ = (1 − w²) / (w² β), θ > 90°.
      {"EUCM 640 480 168.2 167.9 321.7 239.4 0.64 1.12",
       [](const std::vector<double>& p) {
         const double w = unified_w(p[4]);
         return kPi - std::atan(std::sqrt((1 - w * w) / (w * w * p[5])));
       }},
      // ξ + cos θ = −w1 sqrt(sin² θ + (ξ + cos θ)²): a quadratic in x = cos θ,
      // x² + 2ξ(1 − w1²) x + (1 − w1²) ξ² − w1² = 0, the root with ξ + x < 0.
      {"DOUBLE_SPHERE 640 480 150.3 150.1 320.6 239.8 -0.18 0.59",
       [](const std::vector<double>& p) {
         const double xi = p[4], w = unified_w(p[5]), v = 1 - w * w;
         const double x = -xi * v - std::sqrt(xi * xi * v * v - v * xi * xi + w * w);
         return std::acos(x);
       }},
  };
  return cameras;
}

class WideCameraTest : public ::testing::TestWithParam<WideCamera> {};

// Rays between 90 degrees and the lens limit project, and unproject to themselves.
void expect_rays_beyond_ninety_degrees_round_trip(const Camera& camera, double limit) {
  ASSERT_GT(limit, kPi / 2 + 0.3) << "not a camera over 180 degrees";
  std::vector<double> thetas;
  for (double theta = kPi / 2 + 0.02; theta < limit - 1e-3; theta += 0.02) thetas.push_back(theta);
  thetas.push_back(limit - 1e-3);
  for (const double phi : {0.3, 2.0, 4.4}) {
    const auto rays = rays_at(thetas, phi);
    ASSERT_TRUE((rays.select(-1, 2) < 0).all().item<bool>());
    const auto pixels = camera.project(rays);
    ASSERT_TRUE(pixels.valid.all().item<bool>()) << "a ray before the lens limit is invalid";
    const auto back = camera.unproject(pixels.pixels);
    ASSERT_TRUE(back.valid.all().item<bool>());
    EXPECT_LE((back.rays - rays).norm(2, -1).max().item<double>(), 1e-9);
  }
}

// Rays and pixels just inside the limit are valid, just beyond it invalid.
void expect_limit_separates_valid_from_invalid(const Camera& camera, double limit) {
  for (const double phi : {0.0, 1.1, 3.9}) {
    const auto rays = rays_at({limit - 1e-4, limit + 1e-4, limit + 0.1, kPi}, phi);
    const auto pixels = camera.project(rays);
    EXPECT_TRUE(pixels.valid[0].item<bool>());
    EXPECT_FALSE(pixels.valid.narrow(0, 1, 3).any().item<bool>()) << "beyond the limit";
    // Pixels just inside and just outside the image of the limit, along the same azimuth.
    const auto centre = at::tensor({camera.params()[2], camera.params()[3]}, at::kDouble);
    const auto edge = pixels.pixels[0] - centre;
    const auto probes = at::stack({centre + 0.999 * edge, centre + 1.001 * edge});
    const auto back = camera.unproject(probes);
    EXPECT_TRUE(back.valid[0].item<bool>());
    EXPECT_FALSE(back.valid[1].item<bool>()) << "beyond the image of the limit";
  }
}

// Pixel -> ray -> pixel over a ray map whose corners lie beyond the lens's limit.
void expect_ray_map_round_trip(const Camera& camera) {
  SCOPED_TRACE(camera.to_spec());
  for (const auto dtype : {at::kFloat, at::kDouble}) {
    const auto map = camera.ray_map(dtype);
    EXPECT_FALSE(map.valid.all().item<bool>()) << "the corners lie beyond the limit";
    const auto z = map.rays.select(-1, 2);
    EXPECT_GT(max_where(map.valid, -z), 0.2) << "no pixel sees behind the image plane";
    const auto projected = camera.project(map.rays);
    EXPECT_TRUE(at::equal(map.valid & projected.valid, map.valid));
    const auto error = (projected.pixels - camera.pixel_centres(dtype)).norm(2, -1);
    EXPECT_LE(max_where(map.valid, error), dtype == at::kFloat ? 1e-3 : 1e-6);
  }
}

// One test per camera (every test is a process, and LibTorch takes a while to load).
TEST_P(WideCameraTest, BeyondNinetyDegreesUpToTheLensLimit) {
  const auto camera = parse_camera(GetParam().spec);
  const double limit = GetParam().limit_angle(camera.params());
  expect_rays_beyond_ninety_degrees_round_trip(camera, limit);
  expect_limit_separates_valid_from_invalid(camera, limit);
  expect_ray_map_round_trip(camera);
}

TEST(KannalaBrandt, ThinPrismRayMapRoundTripsWithTheFoldInView) {
  // The radial part folds at 125 degrees, the small tangential and prism terms bend the fold.
  expect_ray_map_round_trip(parse_camera(
      "THIN_PRISM_FISHEYE 640 480 183.7 184.2 319.3 241.6 0.0342 -0.0147 0.0004 -0.0003 0.0021 "
      "-0.0003 0.0005 -0.0002"));
}

INSTANTIATE_TEST_SUITE_P(Fisheyes, WideCameraTest, ::testing::ValuesIn(wide_cameras()),
                         [](const ::testing::TestParamInfo<WideCamera>& info) {
                           return info.param.spec.substr(0, info.param.spec.find(' '));
                         });

TEST(KannalaBrandt, EquidistantBeyondNinetyDegreesMatchesTheFormula) {
  // pixel = c + f θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸) (cos φ, sin φ), at θ up to 120°.
  const std::vector<double> p = {183.7, 184.2, 319.3, 241.6, 0.0342, -0.0147, 0.0021, -0.0003};
  const Camera camera("OPENCV_FISHEYE", 640, 480, p);
  const double phi = 0.7;
  const std::vector<double> thetas = {0.0, 0.4, 1.2, kPi / 2, 1.9, 2.09};
  const auto pixels = camera.project(rays_at(thetas, phi));
  ASSERT_TRUE(pixels.valid.all().item<bool>());
  for (std::size_t i = 0; i < thetas.size(); ++i) {
    const double t = thetas[i];
    const double theta_d = t * (1 + p[4] * t * t + p[5] * std::pow(t, 4) + p[6] * std::pow(t, 6) +
                                p[7] * std::pow(t, 8));
    EXPECT_NEAR(pixels.pixels[i][0].item<double>(), p[2] + p[0] * theta_d * std::cos(phi), 1e-9);
    EXPECT_NEAR(pixels.pixels[i][1].item<double>(), p[3] + p[1] * theta_d * std::sin(phi), 1e-9);
  }
}

TEST(KannalaBrandt, LensLimit) {
  // 1 + 3 k θ² = 0 at θ = sqrt(−1 / (3k)); rising everywhere: π.
  EXPECT_NEAR(theta_limit({-0.1}), std::sqrt(1.0 / 0.3), 1e-12);
  EXPECT_DOUBLE_EQ(theta_limit({}), kPi);
  EXPECT_DOUBLE_EQ(theta_limit({0.02, -0.001}), kPi);
  const Camera camera("SIMPLE_RADIAL_FISHEYE", 640, 480, {150, 320, 240, -0.1});
  const double limit = std::sqrt(1.0 / 0.3);
  const auto pixels = camera.project(rays_at({limit - 1e-6, limit + 1e-6}, 0.4));
  EXPECT_TRUE(pixels.valid[0].item<bool>());
  EXPECT_FALSE(pixels.valid[1].item<bool>());
}

TEST(KannalaBrandt, ThinPrismTermsMatchTheFormula) {
  // Only sx1, sy1: pixel = c + f (θ cos φ + sx1 θ², θ sin φ + sy1 θ²).
  const Camera camera("THIN_PRISM_FISHEYE", 640, 480,
                      {200, 210, 320, 240, 0, 0, 0, 0, 0, 0, 0.001, -0.002});
  const double theta = 1.9, phi = 2.5;
  const auto pixels = camera.project(rays_at({theta}, phi));
  ASSERT_TRUE(pixels.valid.all().item<bool>());
  EXPECT_NEAR(pixels.pixels[0][0].item<double>(),
              320 + 200 * (theta * std::cos(phi) + 0.001 * theta * theta), 1e-9);
  EXPECT_NEAR(pixels.pixels[0][1].item<double>(),
              240 + 210 * (theta * std::sin(phi) - 0.002 * theta * theta), 1e-9);
}

// Two specs that describe the same camera: projections of rays over the whole sphere and
// unprojections of pixels far beyond the image agree, validity included.
void expect_same_camera(const std::string& a_spec, const std::string& b_spec) {
  SCOPED_TRACE(a_spec + " vs " + b_spec);
  const auto a = parse_camera(a_spec);
  const auto b = parse_camera(b_spec);
  const auto rays = random_directions(4000);
  const auto pa = a.project(rays);
  const auto pb = b.project(rays);
  EXPECT_TRUE(at::equal(pa.valid, pb.valid));
  ASSERT_GT(pa.valid.sum().item<int64_t>(), 100);
  // Relative: next to a domain edge at infinity (α < 0.5) pixels grow without bound.
  const auto difference = (pa.pixels - pb.pixels).norm(2, -1) / (1 + pa.pixels.norm(2, -1));
  EXPECT_LE(max_where(pa.valid, difference), 1e-13);

  const auto xs = at::linspace(-1.5 * a.width(), 2.5 * a.width(), 53, at::kDouble);
  const auto ys = at::linspace(-1.5 * a.height(), 2.5 * a.height(), 41, at::kDouble);
  const auto grid = at::stack(at::meshgrid({xs, ys}, "xy"), -1);
  const auto ua = a.unproject(grid);
  const auto ub = b.unproject(grid);
  EXPECT_TRUE(at::equal(ua.valid, ub.valid));
  EXPECT_LE((ua.rays - ub.rays).norm(2, -1).max().item<double>(), 1e-10);
}

TEST(ModelIdentities, UnifiedModels) {
  // UCM with α = 0 is the pinhole camera.
  expect_same_camera("UCM 640 480 300 310 320 240 0", "PINHOLE 640 480 300 310 320 240");
  // EUCM with β = 1 is UCM.
  expect_same_camera("EUCM 640 480 200 210 320 240 0.6 1", "UCM 640 480 200 210 320 240 0.6");
  expect_same_camera("EUCM 640 480 200 210 320 240 0.3 1", "UCM 640 480 200 210 320 240 0.3");
  // DOUBLE_SPHERE with ξ = 0 is UCM (the shift vanishes).
  expect_same_camera("DOUBLE_SPHERE 640 480 200 210 320 240 0 0.6",
                     "UCM 640 480 200 210 320 240 0.6");
  // DOUBLE_SPHERE with α = 0 is the undistorted MEI camera with the same ξ.
  expect_same_camera("DOUBLE_SPHERE 640 480 200 210 320 240 0.7 0",
                     "MEI 640 480 200 210 320 240 0.7 0 0 0 0");
  // UCM(α) is MEI with ξ = α / (1 − α) and f / (1 − α), on both sides of α = 0.5.
  expect_same_camera("UCM 640 480 200 210 320 240 0.6", "MEI 640 480 500 525 320 240 1.5 0 0 0 0");
  expect_same_camera("UCM 640 480 200 210 320 240 0.25",
                     "MEI 640 480 266.66666666666669 280 320 240 0.33333333333333331 0 0 0 0");
}

TEST(ModelIdentities, EquidistantModels) {
  expect_same_camera("SIMPLE_RADIAL_FISHEYE 640 480 200 320 240 -0.02",
                     "OPENCV_FISHEYE 640 480 200 200 320 240 -0.02 0 0 0");
  expect_same_camera("RADIAL_FISHEYE 640 480 200 320 240 -0.02 0.003",
                     "OPENCV_FISHEYE 640 480 200 200 320 240 -0.02 0.003 0 0");
  expect_same_camera(
      "THIN_PRISM_FISHEYE 640 480 200 210 320 240 0.01 -0.002 0 0 0.0003 -0.00002 0 0",
      "OPENCV_FISHEYE 640 480 200 210 320 240 0.01 -0.002 0.0003 -0.00002");
  expect_same_camera(
      "RAD_TAN_THIN_PRISM_FISHEYE 640 480 200 210 320 240 0.01 -0.002 0.0003 -0.00002 0 0 0 0 0 0 "
      "0 0",
      "OPENCV_FISHEYE 640 480 200 210 320 240 0.01 -0.002 0.0003 -0.00002");
  // Without radial terms the two prism models coincide: RAD_TAN's (p0, p1) are OpenCV's
  // (p2, p1) and its s0, s2 are sx1, sy1.
  expect_same_camera(
      "RAD_TAN_THIN_PRISM_FISHEYE 640 480 200 210 320 240 0 0 0 0 0 0 0.0004 -0.0003 0.0006 0 "
      "-0.0005 0",
      "THIN_PRISM_FISHEYE 640 480 200 210 320 240 0 0 -0.0003 0.0004 0 0 0.0006 -0.0005");
}

TEST(ModelIdentities, DoubleSphereWithNegativeXiIsExact) {
  // Usenko et al.'s z > −w2 d1 is not exact for this ξ < 0; the shifted-sphere form is:
  // every ray the camera accepts unprojects to itself, every pixel to a ray it accepts.
  const auto camera = parse_camera("DOUBLE_SPHERE 640 480 150 150 320 240 -0.5 0.9");
  const auto rays = random_directions(20000);
  const auto pixels = camera.project(rays);
  ASSERT_GT(pixels.valid.sum().item<int64_t>(), 1000);
  const auto back = camera.unproject(pixels.pixels);
  EXPECT_TRUE(at::equal(back.valid & pixels.valid, pixels.valid));
  EXPECT_LE(max_where(pixels.valid, (back.rays - rays).norm(2, -1)), 1e-9);
  // The published test would accept rays that fold back onto others:
  const double w1 = unified_w(0.9), xi = -0.5;
  const double w2 = (w1 + xi) / std::sqrt(2 * w1 * xi + xi * xi + 1);
  const auto published = rays.select(-1, 2) > -w2;
  EXPECT_GT((published & ~pixels.valid).sum().item<int64_t>(), 0);
}

void expect_rejected(const std::string& spec, const std::vector<std::string>& words) {
  try {
    parse_camera(spec);
    ADD_FAILURE() << "accepted: " << spec;
  } catch (const std::invalid_argument& error) {
    const std::string message = error.what();
    for (const auto& word : words) {
      EXPECT_NE(message.find(word), std::string::npos) << message << " lacks " << word;
    }
  }
}

TEST(ParameterRules, ClearErrors) {
  expect_rejected("OPENCV_FISHEYE 640 480 0 200 320 240 0 0 0 0", {"OPENCV_FISHEYE", "fx", "> 0"});
  expect_rejected("SIMPLE_RADIAL_FISHEYE 640 480 -5 320 240 0", {"SIMPLE_RADIAL_FISHEYE", "f"});
  expect_rejected("THIN_PRISM_FISHEYE 640 480 200 0 320 240 0 0 0 0 0 0 0 0",
                  {"THIN_PRISM_FISHEYE", "fy"});
  expect_rejected("RAD_TAN_THIN_PRISM_FISHEYE 640 480 200 200 320 240 0 0 0",
                  {"RAD_TAN_THIN_PRISM_FISHEYE", "16", "k0", "s3"});
  expect_rejected("UCM 640 480 200 200 320 240 -0.1", {"UCM", "alpha", "[0, 1]", "-0.1"});
  expect_rejected("EUCM 640 480 200 200 320 240 1.5 1", {"EUCM", "alpha", "[0, 1]"});
  expect_rejected("EUCM 640 480 200 200 320 240 0.5 0", {"EUCM", "beta", "> 0"});
  expect_rejected("DOUBLE_SPHERE 640 480 200 200 320 240 1 0.5",
                  {"DOUBLE_SPHERE", "xi", "(-1, 1)"});
  expect_rejected("DOUBLE_SPHERE 640 480 200 200 320 240 0 1.2", {"DOUBLE_SPHERE", "alpha"});
  expect_rejected("MEI 640 480 200 200 320 240 -0.2 0 0 0 0", {"MEI", "xi", ">= 0"});
  expect_rejected("MEI 640 480 200 200 320 240 1 0 0 0", {"MEI", "9"});
  expect_rejected("EUCM 640 480 200 200 320 240 nan 1", {"EUCM"});
}

}  // namespace
}  // namespace omnipoint::camera
