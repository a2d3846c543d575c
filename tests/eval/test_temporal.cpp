// Temporal stability (eval/temporal.h): closed-form cases on a plane seen from two known poses
// (ground truth gives 0; a known scale jump gives it back), a rendered camera path's ground truth
// scored through the eval command's reader, and bad shapes.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/camera_path.h"
#include "omnipoint/eval/temporal.h"
#include "omnipoint/io/npy.h"

namespace omnipoint::eval {
namespace {

namespace fs = std::filesystem;

// A rotation of `degrees` about the camera's y axis and a translation, as a (4, 4) pose.
at::Tensor pose(double degrees, double x, double y, double z) {
  const double a = degrees * M_PI / 180.0;
  at::Tensor m = at::eye(4, at::kDouble);
  m[0][0] = std::cos(a);
  m[0][2] = std::sin(a);
  m[2][0] = -std::sin(a);
  m[2][2] = std::cos(a);
  m[0][3] = x;
  m[1][3] = y;
  m[2][3] = z;
  return m;
}

// The true frame of a camera at `world_from_camera` looking at the world plane z = 5.
SequenceFrame plane_frame(const camera::Camera& camera, const at::Tensor& world_from_camera) {
  const camera::Rays rays = camera.ray_map(at::kDouble);
  const at::Tensor rotation = world_from_camera.slice(0, 0, 3).slice(1, 0, 3);
  const double centre_z = world_from_camera[2][3].item<double>();
  const at::Tensor world_z = at::matmul(rays.rays, rotation.t()).select(-1, 2);
  const at::Tensor t = (5.0 - centre_z) / world_z;
  return {(rays.rays * t.unsqueeze(-1)).to(at::kFloat), rays.valid & (t > 0), world_from_camera};
}

const camera::Camera kCamera{"PINHOLE", 64, 48, {50, 50, 32, 24}};

TEST(TemporalStability, GroundTruthGivesZero) {
  const std::vector<SequenceFrame> frames = {plane_frame(kCamera, pose(0, 0, 0, 0)),
                                             plane_frame(kCamera, pose(2, 0.1, 0, 0.2)),
                                             plane_frame(kCamera, pose(4, 0.2, 0.05, 0.4))};
  const TemporalStability stability = temporal_stability(frames, kCamera);
  ASSERT_EQ(stability.pairs.size(), 2u);
  for (const PairStability& pair : stability.pairs) {
    EXPECT_GT(pair.pixels, 64 * 48 / 2);  // most of frame t lands in frame t+1
    EXPECT_LT(pair.error, 1e-4);          // the bilinear sampling of a curved map only
  }
  EXPECT_LT(stability.error, 1e-4);
}

TEST(TemporalStability, AScaleJumpGivesItsSize) {
  SequenceFrame first = plane_frame(kCamera, pose(0, 0, 0, 0));
  SequenceFrame second = plane_frame(kCamera, pose(2, 0.1, 0, 0.2));
  // Frame 2 only turns (a scaled point carried by a translation would leave its ray).
  SequenceFrame third = plane_frame(kCamera, pose(4, 0.1, 0, 0.2));
  second.points = second.points * 1.1;  // frame 1's scale jumps by 10 %, frame 2's is right
  const TemporalStability stability = temporal_stability({first, second, third}, kCamera);
  ASSERT_EQ(stability.pairs.size(), 2u);
  EXPECT_NEAR(stability.pairs[0].error, 0.1, 1e-3);          // |1.1 - 1|
  EXPECT_NEAR(stability.pairs[1].error, 1 - 1 / 1.1, 1e-3);  // |1/1.1 - 1|
  EXPECT_NEAR(stability.error, (0.1 + (1 - 1 / 1.1)) / 2, 1e-3);
}

TEST(TemporalStability, NoOverlapIsNaNAndLeftOutOfTheMean) {
  const SequenceFrame first = plane_frame(kCamera, pose(0, 0, 0, 0));
  SequenceFrame away = plane_frame(kCamera, pose(0, 0, 0, 0));
  away.world_from_camera = pose(180, 0, 0, 0);  // looking away: nothing lands in its image
  const PairStability pair = temporal_pair_stability(first, away, kCamera);
  EXPECT_EQ(pair.pixels, 0);
  EXPECT_TRUE(std::isnan(pair.error));
  const TemporalStability stability =
      temporal_stability({first, plane_frame(kCamera, pose(2, 0.1, 0, 0.2))}, kCamera);
  EXPECT_LT(stability.error, 1e-4);
}

TEST(TemporalStability, ShapesThatDisagreeAreRejected) {
  SequenceFrame frame = plane_frame(kCamera, pose(0, 0, 0, 0));
  SequenceFrame small = frame;
  small.points = frame.points.slice(0, 0, 10);
  EXPECT_THROW(temporal_pair_stability(frame, small, kCamera), std::invalid_argument);
  SequenceFrame no_pose = frame;
  no_pose.world_from_camera = at::eye(3, at::kDouble);
  EXPECT_THROW(temporal_pair_stability(frame, no_pose, kCamera), std::invalid_argument);
}

// A rendered camera path's own ground truth, written as predict would write it, scores ~0
// through the reader of `eval --sequence`; a missing frame is an error naming it.
TEST(TemporalStability, RenderedPathGroundTruthScoresZero) {
  const fs::path dir = fs::temp_directory_path() / "omnipoint_temporal_path";
  fs::remove_all(dir);
  data::synth::CameraPathOptions options;
  options.camera = camera::Camera("PINHOLE", 48, 36, {30, 30, 24, 18});
  options.frames = 3;
  options.step = 0.1;
  options.yaw_step_deg = 2;
  options.synth.render.shadows = false;
  options.synth.render.ambient_occlusion = false;
  const std::vector<std::string> names =
      data::synth::write_camera_path((dir / "path").string(), options);
  ASSERT_EQ(names.size(), 3u);
  for (const std::string& name : names) {
    EXPECT_TRUE(fs::is_regular_file(dir / "path" / "frames" / (name + ".png")));
    const data::Sample truth = data::read_sample((dir / "path" / "truth" / name).string());
    const at::Tensor rays = options.camera.ray_map(at::kFloat).rays;
    const at::Tensor points = rays * truth.distance.unsqueeze(-1) * truth.mask.unsqueeze(-1);
    fs::create_directories(dir / "predicted" / name);
    io::write_npy((dir / "predicted" / name / "points.npy").string(), points.contiguous());
  }
  const std::vector<data::synth::CameraPathFrame> path =
      data::synth::read_camera_path((dir / "path").string());
  ASSERT_EQ(path.size(), 3u);
  // The poses: the path moves 0.1 m per frame.
  const double moved =
      at::linalg_vector_norm(
          path[1].world_from_camera.select(1, 3) - path[0].world_from_camera.select(1, 3), 2, {0})
          .item<double>();
  EXPECT_NEAR(moved, 0.1, 1e-9);
  const TemporalStability stability =
      score_predicted_sequence((dir / "predicted").string(), (dir / "path").string());
  ASSERT_EQ(stability.pairs.size(), 2u);
  EXPECT_GT(stability.pairs[0].pixels, 200);
  EXPECT_LT(stability.error, 2e-3);
  fs::remove_all(dir / "predicted" / names.back());
  EXPECT_THROW(score_predicted_sequence((dir / "predicted").string(), (dir / "path").string()),
               std::invalid_argument);
  // A path is written whole into an empty or new folder only.
  EXPECT_THROW(data::synth::write_camera_path((dir / "path").string(), options),
               std::invalid_argument);
  options.frames = 1;
  EXPECT_THROW(data::synth::write_camera_path((dir / "other").string(), options),
               std::invalid_argument);
  EXPECT_FALSE(fs::exists(dir / "other"));
  fs::remove_all(dir);
}

}  // namespace
}  // namespace omnipoint::eval
