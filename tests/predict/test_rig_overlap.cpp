// predict::reconcile_overlap_scales (the overlap rule of `predict --rig`) in closed form: cameras
// inside a sphere, whose distance along any ray is known exactly, with their distances
// multiplied by known wrong factors. The rule must bring the overlapping cameras to one scale
// (a fisheye beyond 180 degrees and a panorama among them), leave a camera that overlaps nothing
// alone, keep a LiDAR-aligned camera fixed as the anchor, and report no residual where nothing
// overlaps.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/predict/rig_overlap.h"
#include "predict/rig_poses.h"
#include "support/expect_error.h"

namespace omnipoint::predict {
namespace {

using test_rig::pose;
using test_rig::rotation_x;
using test_rig::rotation_y;

// The sphere: centre and radius in the body frame.
const std::vector<double> kCentre = {0.4, -0.3, 0.6};
constexpr double kRadius = 6.0;

struct Mount {
  std::string spec;
  at::Tensor body_from_camera;
};

const std::map<std::string, Mount>& mounts() {
  static const std::map<std::string, Mount> all = {
      {"front", {"PINHOLE 64 48 40 40 32 24", pose(rotation_x(-0.1), {0.0, 0.05, 0.5})}},
      {"front_right",  // a pinhole turned 40 degrees: half its view is front's
       {"PINHOLE 64 48 40 40 32 24", pose(rotation_y(0.7), {0.4, 0.0, 0.3})}},
      {"left",  // beyond 180 degrees
       {"MEI 48 48 24 24 24 24 1.35 0 0 0 0", pose(rotation_y(-M_PI / 2), {-0.5, 0.0, 0.0})}},
      {"top", {"EQUIRECTANGULAR 64 32", pose(rotation_y(0.3), {0.0, -0.6, 0.1})}},
      {"back", {"PINHOLE 48 36 40 40 24 18", pose(rotation_y(M_PI), {0.0, 0.0, -0.5})}},
  };
  return all;
}

// A camera of the mounts seeing the sphere, its distances times `factor`.
OverlapCamera view(const std::string& name, double factor = 1, bool anchored = false) {
  const Mount& mount = mounts().at(name);
  const camera::Camera camera = camera::parse_camera(mount.spec);
  const camera::Rays rays = camera.ray_map(at::kDouble);
  const at::Tensor rotation = mount.body_from_camera.slice(0, 0, 3).slice(1, 0, 3);
  const at::Tensor origin = mount.body_from_camera.slice(0, 0, 3).select(1, 3);
  // |o + t r - c| = R: t = -(o - c).r + sqrt(((o - c).r)^2 - |o - c|^2 + R^2).
  const at::Tensor offset = origin - at::tensor(kCentre, at::kDouble);
  const at::Tensor along = rays.rays.matmul(rotation.t()).matmul(offset);
  const at::Tensor distance =
      -along + (along * along - offset.dot(offset) + kRadius * kRadius).sqrt();
  return {camera,
          mount.body_from_camera,
          rays.rays.to(at::kFloat),
          (distance * factor * rays.valid).to(at::kFloat),
          rays.valid,
          factor,
          anchored};
}

// The disagreement the truth itself leaves over these cameras' overlaps: the panorama's coarse
// pixels read the sphere a chord short (~1e-3); a reconciled rig should leave no more than that.
double truth_residual(const std::vector<std::string>& names) {
  std::vector<OverlapCamera> cameras;
  for (const std::string& name : names) cameras.push_back(view(name));
  return *measure_overlaps(cameras).residual;
}

TEST(RigOverlap, BringsWronglyScaledCamerasToOneScale) {
  const std::vector<std::string> names = {"front", "front_right", "left", "top"};
  // Their median (of the middle two) is 1: the rule's level (the median correction is 1) is the
  // true scale. (At another common level the cameras would not quite agree: the baselines
  // between them do not scale with the distances.)
  const std::vector<double> wrong = {0.8, 1.0 / 0.9, 0.9, 1.6};
  std::vector<OverlapCamera> cameras;
  for (size_t c = 0; c < names.size(); ++c) cameras.push_back(view(names[c], wrong[c]));
  // Before: the pairs disagree by their factors.
  const OverlapResult before = measure_overlaps(cameras);
  ASSERT_TRUE(before.residual);
  EXPECT_GT(*before.residual, 0.1);

  const OverlapResult result = reconcile_overlap_scales(cameras);
  ASSERT_TRUE(result.residual);
  EXPECT_LT(*result.residual, 1e-4 + truth_residual(names));
  EXPECT_GE(result.pairs.size(), 6u);
  // Every camera's final scale (its wrong factor times the correction) is one common scale: the
  // median of the corrections is 1 (no anchor), so the common scale is the wrong factors'
  // median, 1.
  const double common = 1.0;
  for (size_t c = 0; c < names.size(); ++c) {
    SCOPED_TRACE(names[c]);
    EXPECT_TRUE(result.reconciled[c]);
    EXPECT_EQ(result.group[c], result.group[0]);
    EXPECT_NEAR(wrong[c] * result.factors[c] / common, 1.0, 1e-4);
    std::printf("%s: wrong %.3f, corrected to %.6f\n", names[c].c_str(), wrong[c],
                wrong[c] * result.factors[c]);
  }
  // Each pair agrees to the chord of the sphere across a pixel: the panorama's pixels (5.6
  // degrees) read its pairs ~1e-3 short, the truth's too (TheTruthIsLeftAsItIs prints them).
  for (const OverlapPair& pair : result.pairs) {
    EXPECT_GE(pair.inliers, kOverlapMinPixels);
    EXPECT_NEAR(pair.log_ratio, 0.0, 2e-3);
  }
  std::printf("residual before %.4f, after %.2e\n", *before.residual, *result.residual);
}

TEST(RigOverlap, TheTruthIsLeftAsItIs) {
  std::vector<OverlapCamera> cameras;
  const std::vector<std::string> names = {"front", "front_right", "left", "top", "back"};
  for (const std::string& name : names) cameras.push_back(view(name));
  const OverlapResult result = reconcile_overlap_scales(cameras);
  ASSERT_TRUE(result.residual);
  EXPECT_LT(*result.residual, 1e-4 + truth_residual(names));
  for (size_t c = 0; c < cameras.size(); ++c) EXPECT_NEAR(result.factors[c], 1.0, 1e-3);
  for (const OverlapPair& pair : result.pairs)
    std::printf("%zu sees %zu: %lld pixels, %lld inliers, log ratio %.2e, residual %.2e\n", pair.i,
                pair.j, static_cast<long long>(pair.pixels), static_cast<long long>(pair.inliers),
                pair.log_ratio, pair.residual);
  // The panorama sees every other camera's points.
  for (size_t j = 0; j < cameras.size(); ++j) {
    if (j == 3) continue;
    bool found = false;
    for (const OverlapPair& pair : result.pairs) found = found || (pair.i == 3 && pair.j == j);
    EXPECT_TRUE(found) << j;
  }
}

TEST(RigOverlap, CamerasThatOverlapNothingAreLeftAlone) {
  // front and back look away from each other: nothing to reconcile, no residual.
  const OverlapResult none = reconcile_overlap_scales({view("front", 0.8), view("back", 1.3)});
  EXPECT_FALSE(none.residual);
  EXPECT_TRUE(none.pairs.empty());
  EXPECT_EQ(none.factors, (std::vector<double>{1.0, 1.0}));
  EXPECT_EQ(none.reconciled, (std::vector<bool>{false, false}));
  EXPECT_EQ(none.group, (std::vector<int>{-1, -1}));
  // With a third camera overlapping front, back is still alone.
  const OverlapResult some = reconcile_overlap_scales(
      {view("front", 0.8), view("back", 1.3), view("front_right", 1.0 / 0.8)});
  ASSERT_TRUE(some.residual);
  EXPECT_EQ(some.reconciled, (std::vector<bool>{true, false, true}));
  EXPECT_EQ(some.group[1], -1);
  EXPECT_EQ(some.factors[1], 1.0);
  // Two cameras: the median of the corrections is 1 -> the geometric mean of their scales, 1.
  EXPECT_NEAR(0.8 * some.factors[0], 1.0, 1e-3);
  EXPECT_NEAR(some.factors[2] / 0.8, 1.0, 1e-3);
  // A larger minimum than the overlap has: the pair does not count.
  OverlapOptions strict;
  strict.min_pixels = int64_t{64} * 48;
  EXPECT_FALSE(
      reconcile_overlap_scales({view("front", 0.8), view("front_right", 1.2)}, strict).residual);
}

TEST(RigOverlap, LidarAlignedCamerasAreAnchors) {
  // top was aligned to a sweep (its scale is right): the others come to it, it does not move.
  const OverlapResult result = reconcile_overlap_scales(
      {view("front", 0.7), view("top", 1.0, true), view("left", 1.4), view("back", 1.2)});
  ASSERT_TRUE(result.residual);
  EXPECT_LT(*result.residual, 1e-4 + truth_residual({"front", "top", "left", "back"}));
  EXPECT_EQ(result.factors[1], 1.0);
  EXPECT_FALSE(result.reconciled[1]);
  EXPECT_NEAR(0.7 * result.factors[0], 1.0, 1e-3);
  EXPECT_NEAR(1.4 * result.factors[2], 1.0, 1e-3);
  EXPECT_NEAR(1.2 * result.factors[3], 1.0, 1e-3);
  // Without an anchor in their group, cameras are levelled to free_group_scale when given (the
  // median of the corrections being 1 would give sqrt(1.4 * 1.8)).
  OverlapOptions level;
  level.free_group_scale = 1.0;
  // (view() gives each camera its factor as its scale so far: the scale its distances are at.)
  const OverlapResult free =
      reconcile_overlap_scales({view("front", 1.4), view("front_right", 1.8)}, level);
  EXPECT_NEAR(1.4 * free.factors[0], 1.0, 1e-3);
  EXPECT_NEAR(1.8 * free.factors[1], 1.0, 1e-3);
}

TEST(RigOverlap, ForegroundThatOneCameraSeesDropsOut) {
  // front's view of the right edge of the wall is blocked at a quarter of the way by an object
  // (its distances there are a quarter): front_right's points behind it are not front's surface.
  OverlapCamera front = view("front", 0.8);
  front.distance.slice(1, 56, 64).mul_(0.25);
  const OverlapResult result = reconcile_overlap_scales({front, view("front_right", 1.0 / 0.8)});
  ASSERT_TRUE(result.residual);
  EXPECT_NEAR(0.8 * result.factors[0], 1.0, 1e-3);
  EXPECT_NEAR(result.factors[1] / 0.8, 1.0, 1e-3);
}

TEST(RigOverlap, ACorruptedRegionDoesNotMoveTheScales) {
  // 30 % of front_right's rows (its overlap with front and top among them) come out twice as far:
  // the band drops those pixels from each pair, the rest still recover the factors.
  const std::vector<std::string> names = {"front", "front_right", "left", "top"};
  const std::vector<double> wrong = {0.8, 1.0 / 0.9, 0.9, 1.6};
  std::vector<OverlapCamera> cameras;
  for (size_t c = 0; c < names.size(); ++c) cameras.push_back(view(names[c], wrong[c]));
  cameras[1].distance.slice(0, 10, 24).mul_(2.0);
  const OverlapResult result = reconcile_overlap_scales(cameras);
  for (size_t c = 0; c < names.size(); ++c) {
    SCOPED_TRACE(names[c]);
    EXPECT_TRUE(result.reconciled[c]);
    EXPECT_NEAR(wrong[c] * result.factors[c], 1.0, 2e-3);
  }
  for (const OverlapPair& pair : result.pairs) {
    if (pair.i == 1 || pair.j == 1) {
      EXPECT_LT(pair.inliers, pair.pixels);
    }
  }
}

TEST(RigOverlap, OneBadPairDoesNotDragTheCameras) {
  // front's right part (what front_right sees of it) comes out 30 % too far: the pair front /
  // front_right says 0.26 in log that the path through top does not. Its residual is many of
  // its standard errors, so Huber's weight bounds its pull (to within 1 %); least squares alone
  // splits it between the cameras (8 % off).
  const std::vector<double> wrong = {0.8, 1.25, 1.0};
  const auto cameras = [&] {
    std::vector<OverlapCamera> c = {view("front", wrong[0]), view("front_right", wrong[1]),
                                    view("top", wrong[2])};
    c[0].distance.slice(1, 40, 64).mul_(1.3);
    return c;
  };
  const OverlapResult robust = reconcile_overlap_scales(cameras());
  OverlapOptions plain;
  plain.huber = 1e6;
  const OverlapResult least_squares = reconcile_overlap_scales(cameras(), plain);
  double worst_plain = 0;
  for (size_t c = 0; c < wrong.size(); ++c) {
    SCOPED_TRACE(c);
    EXPECT_NEAR(wrong[c] * robust.factors[c], 1.0, 1e-2);
    worst_plain = std::max(worst_plain, std::abs(wrong[c] * least_squares.factors[c] - 1));
    std::printf("camera %zu: robust %.5f, least squares %.5f\n", c, wrong[c] * robust.factors[c],
                wrong[c] * least_squares.factors[c]);
  }
  EXPECT_GT(worst_plain, 0.05);
  // The bad pair's weight is below every good pair's.
  bool bad_seen = false;
  double bad_weight = 0, good_weight = 1;
  for (const OverlapPair& pair : robust.pairs) {
    const bool bad = (pair.i == 0 && pair.j == 1) || (pair.i == 1 && pair.j == 0);
    bad_seen = bad_seen || bad;
    std::printf("%zu sees %zu: sigma %.4f, weight %.3f\n", pair.i, pair.j, pair.sigma, pair.weight);
    if (bad)
      bad_weight = std::max(bad_weight, pair.weight);
    else
      good_weight = std::min(good_weight, pair.weight);
  }
  EXPECT_LT(bad_weight, 0.5);
  EXPECT_LT(bad_weight, good_weight);
  EXPECT_TRUE(bad_seen);
}

TEST(RigOverlap, WeakEvidenceMovesTheCamerasLessThanStrong) {
  // front and front_right, their distances off by 0.8 and 1.25: where their whole overlap is
  // consistent the pair overrules the priors and both come to the truth. Where front has only a
  // few valid pixels in the overlap and those are noisy, the pair's standard error is larger and
  // the priors (the network's scales) keep the cameras closer to where they were: the pair moves
  // log(front / front_right) by prior / (prior + its variance) of what it measures.
  // (Options where the two are of a size, so that the closed form below says something: with
  // the defaults the weak pair moves the cameras by under 10 % of what it measures, checked last.)
  OverlapOptions options;
  options.prior_sigma = 0.1;
  options.pixel_correlation = 0.5;
  options.huber = 1e6;  // the least squares alone (a pair this far from the priors is downweighted)
  const auto moved = [&](const OverlapResult& r) {
    return std::log(0.8 * r.factors[0]) - std::log(1.25 * r.factors[1]) + std::log(1.25 / 0.8);
  };
  const OverlapResult strong =
      reconcile_overlap_scales({view("front", 0.8), view("front_right", 1.25)}, options);
  ASSERT_EQ(strong.pairs.size(), 2u);
  EXPECT_NEAR(0.8 * strong.factors[0], 1.0, 1e-3);
  EXPECT_NEAR(1.25 * strong.factors[1], 1.0, 1e-3);

  OverlapCamera front = view("front", 0.8);
  // A block of 12 x 10 pixels towards front's right edge (inside front_right's view), each off by
  // a factor within the band: exp(+-0.12, +-0.06, 0) in a fixed pattern across its columns.
  at::Tensor keep = at::zeros({48, 64}, at::kBool);
  keep.slice(0, 20, 30).slice(1, 50, 62).fill_(true);
  const at::Tensor pattern =
      (at::arange(12, at::kDouble).remainder(5) - 2).mul(0.06).exp().expand({10, 12});
  front.distance.slice(0, 20, 30).slice(1, 50, 62).mul_(pattern.to(at::kFloat));
  front.mask = front.mask & keep;
  front.distance = front.distance * front.mask;
  const OverlapResult weak = reconcile_overlap_scales({front, view("front_right", 1.25)}, options);
  ASSERT_FALSE(weak.pairs.empty());
  const double strong_move = moved(strong), weak_move = moved(weak);
  std::printf("log(front / front_right) moved by %.4f (many consistent pixels), %.4f (few noisy)\n",
              strong_move, weak_move);
  EXPECT_NEAR(strong_move, std::log(1.25 / 0.8), 1e-3);
  EXPECT_GT(weak_move, 0.2 * strong_move);
  EXPECT_LT(weak_move, 0.9 * strong_move);
  // The weighted least squares in closed form: the difference of the two cameras' priors has
  // variance 2 prior_sigma^2, each order of the pair counts 1 / (2 sigma^2); what a pair measured
  // at the start is what it moved plus what it still says (its log ratio at the final scales).
  double precision = 0, measured = 0;
  for (const OverlapPair& pair : weak.pairs) {
    EXPECT_GT(pair.sigma, 0.01);
    EXPECT_DOUBLE_EQ(pair.weight, 1.0);
    precision += 0.5 / (pair.sigma * pair.sigma);
    measured += (weak_move + (pair.i == 0 ? -pair.log_ratio : pair.log_ratio)) /
                static_cast<double>(weak.pairs.size());
  }
  for (const OverlapPair& pair : strong.pairs) EXPECT_LT(pair.sigma, 1e-3);
  const double prior = 1 / (2 * options.prior_sigma * options.prior_sigma);
  EXPECT_NEAR(weak_move, measured * precision / (precision + prior), 0.02);

  // The defaults: the few pixels' spread stands for a ten times larger error common to them.
  const double weak_default = moved(reconcile_overlap_scales({front, view("front_right", 1.25)}));
  const double strong_default =
      moved(reconcile_overlap_scales({view("front", 0.8), view("front_right", 1.25)}));
  std::printf("with the defaults: moved by %.4f (many consistent pixels), %.4f (few noisy)\n",
              strong_default, weak_default);
  EXPECT_NEAR(strong_default, std::log(1.25 / 0.8), 1e-3);
  EXPECT_GT(weak_default, 0.0);
  EXPECT_LT(weak_default, 0.1 * strong_default);
}

TEST(RigOverlap, BadInputIsOneError) {
  OverlapCamera camera = view("front");
  camera.distance = camera.distance.slice(0, 0, 10);
  test::expect_error<std::invalid_argument>([&] { reconcile_overlap_scales({camera}); },
                                            {"overlap", "(H, W)"});
  OverlapOptions options;
  options.band = 0;
  test::expect_error<std::invalid_argument>([&] { options.Check(); }, {"band"});
  options = {};
  options.min_pixels = 0;
  test::expect_error<std::invalid_argument>([&] { options.Check(); }, {"min_pixels"});
  options = {};
  options.prior_sigma = 0;
  test::expect_error<std::invalid_argument>([&] { options.Check(); }, {"prior_sigma"});
  options = {};
  options.pixel_correlation = 1;
  test::expect_error<std::invalid_argument>([&] { options.Check(); }, {"pixel_correlation"});
  options = {};
  options.huber = -1;
  test::expect_error<std::invalid_argument>([&] { options.Check(); }, {"huber"});
}

}  // namespace
}  // namespace omnipoint::predict
