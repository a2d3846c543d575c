// `omnipoint predict --colmap` on a COLMAP reconstruction of a synthetic scene: three views of
// one rendered room, their cameras known, the 3-D points taken from the ground truth, and the
// whole reconstruction moved by a similarity transform (COLMAP's frame and scale are arbitrary).
// With the ground-truth distances in place of the network, the world-frame points must land on
// the scene's transformed points; with the bundled model, the recovered scale must be the
// applied one within 10 %.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/render.h"
#include "omnipoint/data/synth/scene.h"
#include "omnipoint/geometry/alignment.h"
#include "omnipoint/io/colmap.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/predict/colmap_scene.h"
#include "omnipoint/predict/predictor.h"
#include "support/cli_run.h"
#include "support/colmap_writer.h"

namespace omnipoint::predict {
namespace {

namespace fs = std::filesystem;

// The similarity that takes the scene's metric world to the reconstruction's: X' = s Q X + c.
constexpr double kScale = 2.5;
const at::Tensor& similarity_rotation() {
  static const at::Tensor q = [] {
    const double a = 0.7, b = -0.3;  // about z, then about x
    const at::Tensor z =
        at::tensor({std::cos(a), -std::sin(a), 0.0, std::sin(a), std::cos(a), 0.0, 0.0, 0.0, 1.0},
                   at::kDouble)
            .view({3, 3});
    const at::Tensor x =
        at::tensor({1.0, 0.0, 0.0, 0.0, std::cos(b), -std::sin(b), 0.0, std::sin(b), std::cos(b)},
                   at::kDouble)
            .view({3, 3});
    return x.matmul(z);
  }();
  return q;
}
const at::Tensor kOffset = at::tensor({3.0, -1.0, 0.5}, at::kDouble);

at::Tensor transformed(const at::Tensor& world) {  // (..., 3) metric world -> reconstruction
  return kScale * world.matmul(similarity_rotation().t()) + kOffset;
}

// COLMAP's quaternion (w, x, y, z) of a rotation matrix (its largest-component branch).
std::array<double, 4> quaternion(const at::Tensor& r) {
  const auto m = r.accessor<double, 2>();
  const double trace = m[0][0] + m[1][1] + m[2][2];
  std::array<double, 4> q{};
  if (trace > 0) {
    const double s = 2 * std::sqrt(1 + trace);
    q = {s / 4, (m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s};
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const double s = 2 * std::sqrt(1 + m[0][0] - m[1][1] - m[2][2]);
    q = {(m[2][1] - m[1][2]) / s, s / 4, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s};
  } else if (m[1][1] > m[2][2]) {
    const double s = 2 * std::sqrt(1 + m[1][1] - m[0][0] - m[2][2]);
    q = {(m[0][2] - m[2][0]) / s, (m[0][1] + m[1][0]) / s, s / 4, (m[1][2] + m[2][1]) / s};
  } else {
    const double s = 2 * std::sqrt(1 + m[2][2] - m[0][0] - m[1][1]);
    q = {(m[1][0] - m[0][1]) / s, (m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, s / 4};
  }
  return q;
}

struct View {
  std::string name;
  at::Tensor image;     // (H, W, 3) uint8
  at::Tensor distance;  // (H, W) metres
  at::Tensor mask;      // (H, W)
  at::Tensor truth;     // (H, W, 3) the rendered surface in the reconstruction's frame
};

struct Reconstruction {
  camera::Camera camera = camera::parse_camera("PINHOLE 96 72 70 70 48 36");
  at::Tensor rays;
  std::vector<View> views;
  io::ColmapModel model;    // what the reader should return
  test::ColmapScene files;  // the same, for the writer
};

const Reconstruction& reconstruction() {
  static const Reconstruction r = [] {
    Reconstruction r;
    const camera::Rays ray_map = r.camera.ray_map(at::kDouble);
    r.rays = ray_map.rays.to(at::kFloat);
    r.model.cameras.emplace(1, r.camera);
    r.files.cameras.push_back({1, "PINHOLE", 96, 72, {70, 70, 48, 36}});
    data::synth::Scene scene = data::synth::make_scene(data::synth::SceneKind::kIndoor, 11);
    const data::synth::Pose base = scene.pose;
    int64_t next_point = 1;
    for (int k = 0; k < 3; ++k) {
      scene.pose = data::synth::make_pose(
          {base.position[0] + 0.3 * (k - 1), base.position[1] + 0.1 * k, base.position[2]},
          base.yaw + 0.15 * (k - 1), base.pitch, base.roll);
      const data::synth::Render render =
          data::synth::render_scene(scene, ray_map.rays, ray_map.valid);
      // World X = p + R (d r), R camera-to-world.
      const at::Tensor rotation = at::empty({3, 3}, at::kDouble);
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) rotation[i][j] = scene.pose.rotation[i][j];
      const at::Tensor position = at::tensor(
          {scene.pose.position[0], scene.pose.position[1], scene.pose.position[2]}, at::kDouble);
      const at::Tensor camera_points = ray_map.rays * render.distance.unsqueeze(-1);
      const at::Tensor world = camera_points.matmul(rotation.t()) + position;
      View view{"room/view_" + std::to_string(k) + ".png", render.image,
                render.distance.to(at::kFloat), render.mask, transformed(world)};

      // COLMAP's pose in the moved world: R' = R^T Q^T, t' = -R' c - s R^T p.
      const at::Tensor r_cw = rotation.t().matmul(similarity_rotation().t());
      const at::Tensor t_cw = -r_cw.matmul(kOffset) - kScale * rotation.t().matmul(position);
      io::ColmapImage image;
      image.id = k + 1;
      image.camera_id = 1;
      image.name = view.name;
      image.qvec = quaternion(r_cw);
      image.tvec = {t_cw[0].item<double>(), t_cw[1].item<double>(), t_cw[2].item<double>()};
      // Every 7th valid pixel becomes a 3-D point observed at its pixel centre.
      const at::Tensor pixels = render.mask.nonzero();  // (N, 2) row, column
      for (int64_t n = 0; n < pixels.size(0); n += 7) {
        const int64_t row = pixels[n][0].item<int64_t>(), col = pixels[n][1].item<int64_t>();
        const at::Tensor xyz = view.truth[row][col];
        io::ColmapPoint point;
        point.xyz = {xyz[0].item<double>(), xyz[1].item<double>(), xyz[2].item<double>()};
        r.model.points.emplace(next_point, point);
        image.points2d.push_back({col + 0.5, row + 0.5});
        image.point3d_ids.push_back(next_point++);
      }
      image.points2d.push_back({1.0, 1.0});  // an observation without a 3-D point
      image.point3d_ids.push_back(-1);
      r.model.images.push_back(image);
      r.files.images.push_back(image);
      r.views.push_back(view);
    }
    r.files.points = r.model.points;
    return r;
  }();
  return r;
}

// Median over the valid pixels of |predicted - truth| / (truth's distance from the camera).
double median_relative_error(const at::Tensor& predicted, const View& view) {
  const at::Tensor error = (predicted.to(at::kDouble) - view.truth).norm(2, -1);
  const at::Tensor range = kScale * view.distance.to(at::kDouble);
  return (error / range).index({view.mask}).median().item<double>();
}

TEST(ColmapPredict, GroundTruthDistancesLandOnTheTransformedScene) {
  const Reconstruction& r = reconstruction();
  const fs::path dir = test::fresh_process_dir("omnipoint_colmap_oracle");
  for (const bool binary : {false, true}) {
    const fs::path sparse = dir / (binary ? "bin" : "txt");
    if (binary)
      test::write_colmap_binary(sparse, r.files);
    else
      test::write_colmap_text(sparse, r.files);
    const ColmapScene scene = ColmapScene::read(sparse.string());
    ASSERT_EQ(scene.views().size(), 3u);
    for (const View& truth : r.views) {
      SCOPED_TRACE(truth.name);
      const ColmapView* view = scene.find(truth.name);
      ASSERT_NE(view, nullptr);
      EXPECT_EQ(scene.find("view_1.png") == view, truth.name == "room/view_1.png");
      EXPECT_EQ(view->camera, r.camera);
      // The ground truth in place of the network, then what predict does after it: the sparse
      // depth through the image's pose and camera, the one alignment rule, the world frame.
      const at::Tensor sparse_map =
          sparse_distance_map(sparse_depth_of(*view), 96, 72, r.rays, &view->camera);
      const at::Tensor usable = (sparse_map > 0) & truth.mask;
      EXPECT_GT(usable.sum().item<int64_t>(), 50);
      const double factor = geometry::fit_scale_to_sparse_depth(
                                truth.distance.flatten(), sparse_map.flatten(), usable.flatten())
                                .item<double>();
      EXPECT_NEAR(factor, kScale, 1e-3 * kScale);
      const Prediction p =
          prediction_from_geometry(r.rays, truth.distance * factor, truth.mask, factor);
      const double error =
          median_relative_error(world_points(p.points, view->camera_from_world), truth);
      EXPECT_LE(error, 0.005);
      std::printf("%s (%s): alignment %.6f, median relative error %.2e\n", truth.name.c_str(),
                  binary ? "bin" : "txt", factor, error);
    }
  }
  EXPECT_EQ(ColmapScene(r.model).find("elsewhere.png"), nullptr);
}

TEST(ColmapPredict, BundledModelRecoversTheReconstructionScale) {
  const Reconstruction& r = reconstruction();
  const fs::path dir = test::fresh_process_dir("omnipoint_colmap_cli");
  test::write_colmap_binary(dir / "sparse", r.files);
  for (const View& view : r.views) {
    fs::create_directories((dir / "images" / view.name).parent_path());
    io::write_image_png((dir / "images" / view.name).string(), view.image);
  }
  io::write_image_png((dir / "images" / "unregistered.png").string(), r.views[0].image);
  const test::CliRun run = test::run_omnipoint(
      "predict " + (dir / "images").string() + " --colmap " + (dir / "sparse").string() +
          " --out " + (dir / "out").string() + " --model " + OMNIPOINT_SOURCE_DIR +
          "/models/omnipoint_default.safetensors",
      dir / "run");
  ASSERT_EQ(run.status, 0) << run.err;
  EXPECT_NE(run.err.find("COLMAP's scale is arbitrary"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("unregistered.png: not an image of the COLMAP reconstruction"),
            std::string::npos)
      << run.err;
  int64_t fused_expected = 0;
  for (const View& view : r.views) {
    SCOPED_TRACE(view.name);
    const fs::path out = dir / "out" / fs::path(view.name).replace_extension();
    const at::Tensor distance = io::read_npy((out / "distance.npy").string());
    const at::Tensor valid = (distance > 0) & view.mask;
    fused_expected += (distance > 0).sum().item<int64_t>();
    const double recovered =
        (distance.index({valid}).to(at::kDouble) / view.distance.index({valid}).to(at::kDouble))
            .median()
            .item<double>();
    EXPECT_NEAR(recovered, kScale, 0.1 * kScale);
    std::printf("%s: recovered scale %.4f (applied %.2f)\n", view.name.c_str(), recovered, kScale);
    // The world-frame points of the image are its points moved by the inverse pose.
    const io::PlyPoints world = io::read_ply((out / "points_world.ply").string());
    EXPECT_EQ(world.points.size(0), (distance > 0).sum().item<int64_t>());
  }
  const io::PlyPoints fused = io::read_ply((dir / "out" / "fused.ply").string());
  EXPECT_EQ(fused.points.size(0), fused_expected);
}

}  // namespace
}  // namespace omnipoint::predict
