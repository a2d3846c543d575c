// The LiDAR rule of `predict --rig` with the truth in the network's place: a spinning LiDAR's
// sweep (`synth --rig`'s, rendered here), taken into each camera's frame as predict does
// (sparse_distance_map), must give every camera its true scale. The sweep is denser than the
// fisheyes' and the panorama's pixels (many returns per pixel) and cast from 0.45 m beside the
// cameras (returns hidden from a camera land on what it sees in front of them).
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cstdio>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/synth/rig_render.h"
#include "omnipoint/data/synth/scene.h"
#include "omnipoint/geometry/alignment.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/io/rig.h"
#include "omnipoint/predict/predictor.h"

namespace omnipoint::data::synth {
namespace {

// The factor predict's alignment fits to take the true distances to the sparse ones: the true
// scale is 1, so the rule's scale error is factor - 1.
double scale_error(const at::Tensor& truth, const at::Tensor& mask, const at::Tensor& sparse) {
  const at::Tensor usable = (sparse > 0) & mask;
  return geometry::fit_scale_to_sparse_depth(truth.to(at::kDouble).flatten(),
                                             sparse.to(at::kDouble).flatten(), usable.flatten())
             .item<double>() -
         1;
}

TEST(RigLidar, SpinningSweepGivesEveryCameraItsTrueScale) {
  // The set of docs/EVALUATION.md "Rigs": a pinhole, two fisheyes beyond 180 degrees and a
  // panorama; a 32-beam sweep of 720 firings per turn; indoor scenes 11 to 13.
  const io::Rig rig = io::read_rig(OMNIPOINT_SOURCE_DIR "/examples/rig/mixed_rig.json");
  ASSERT_TRUE(rig.lidar);
  RigRenderOptions options;
  options.synth.render.shadows = false;
  options.synth.render.ambient_occlusion = false;
  options.lidar = true;
  options.lidar_pattern.beams = 32;
  options.lidar_pattern.azimuth_steps = 720;
  double worst_nearest = 0;
  for (const std::uint64_t seed : {11, 12, 13}) {
    const Scene scene = make_scene(SceneKind::kIndoor, seed);
    const RigRender render =
        render_rig(scene, rig, world_from_body(scene, options.body_axes, options.yaw), options);
    ASSERT_TRUE(render.lidar_points.defined());
    for (std::size_t c = 0; c < rig.cameras.size(); ++c) {
      const io::RigCamera& camera = rig.cameras[c];
      SCOPED_TRACE(camera.name + ", scene " + std::to_string(seed));
      const Sample& truth = render.cameras[c].synth.sample;
      predict::SparseDepthInput sweep;
      sweep.lidar_points = render.lidar_points;
      sweep.camera_from_lidar =
          at::linalg_inv(camera.body_from_camera).matmul(rig.lidar->body_from_lidar);
      const at::Tensor sparse = predict::sparse_distance_map(
          sweep, camera.camera.width(), camera.camera.height(), {}, &camera.camera);
      ASSERT_GT(((sparse > 0) & truth.mask).sum().item<int64_t>(), 500);
      const double error = scale_error(truth.distance, truth.mask, sparse);
      EXPECT_LT(std::abs(error), 0.01);
      // The plain z-buffer, for the record: the nearest of a pixel's returns biases it short.
      const at::Tensor m = sweep.camera_from_lidar;
      const at::Tensor in_camera = render.lidar_points.matmul(m.slice(0, 0, 3).slice(1, 0, 3).t()) +
                                   m.slice(0, 0, 3).select(1, 3);
      const double nearest =
          scale_error(truth.distance, truth.mask,
                      geometry::sparse_depth_from_points(in_camera, camera.camera).depth);
      worst_nearest = std::max(worst_nearest, std::abs(nearest));
      std::printf(
          "scene %d %-5s: LiDAR rule scale error %+.3f %% (nearest return per pixel %+.3f %%)\n",
          static_cast<int>(seed), camera.name.c_str(), 100 * error, 100 * nearest);
    }
  }
  EXPECT_GT(worst_nearest, 0.01);  // the set shows the bias the rule removes
}

}  // namespace
}  // namespace omnipoint::data::synth
