// The geometry layer's own parallel loops (at::parallel_for over rows or points): on two
// threads each gives exactly what it gives on one, on maps large enough to be split (several
// grains of rows) and with invalid, non-finite and duplicate entries in every part.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "omnipoint/geometry/colormap.h"
#include "omnipoint/geometry/grid_surface.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "support/thread_count.h"

namespace omnipoint::geometry {
namespace {

constexpr int64_t kHeight = 300, kWidth = 400;

// A bumpy surface 2-6 m away with a step, NaNs, infinities and an invalid band.
struct Surface {
  at::Tensor points;    // (H, W, 3)
  at::Tensor distance;  // (H, W)
  at::Tensor mask;      // (H, W) bool
};
Surface surface() {
  at::manual_seed(11);
  const at::Tensor column = at::linspace(-1, 1, kWidth).view({1, kWidth});
  const at::Tensor row = at::linspace(-0.75, 0.75, kHeight).view({kHeight, 1});
  at::Tensor distance = 4 + at::sin(9 * column) * at::cos(7 * row) + (column > 0.3).to(at::kFloat);
  distance = distance + 0.01 * at::rand({kHeight, kWidth});
  distance.index_put_({at::rand({kHeight, kWidth}) < 0.01},
                      std::numeric_limits<float>::quiet_NaN());
  distance.index_put_({at::rand({kHeight, kWidth}) < 0.005},
                      std::numeric_limits<float>::infinity());
  const at::Tensor rays = at::stack({column.expand({kHeight, kWidth}),
                                     row.expand({kHeight, kWidth}), at::ones({kHeight, kWidth})},
                                    -1);
  const at::Tensor unit = rays / rays.norm(2, -1, true);
  at::Tensor mask = at::ones({kHeight, kWidth}, at::kBool);
  mask.slice(0, 100, 110).fill_(false);
  return {unit * distance.unsqueeze(-1), distance, mask};
}

template <typename Run>
void expect_same_on_two_threads(const Run& run) {
  const auto one = [&] {
    const test::ThreadCount count(1);
    return run();
  }();
  const auto two = [&] {
    const test::ThreadCount count(2);
    return run();
  }();
  ASSERT_EQ(one.size(), two.size());
  for (size_t i = 0; i < one.size(); ++i) {
    ASSERT_TRUE(one[i].defined());
    // NaN != NaN: compared as a value no output holds otherwise.
    const auto comparable = [](const at::Tensor& t) {
      return at::isFloatingType(t.scalar_type()) ? at::nan_to_num(t, -1) : t;
    };
    EXPECT_TRUE(at::equal(comparable(two[i]), comparable(one[i]))) << "output " << i;
  }
}

TEST(ParallelLoops, NormalsFromPointMap) {
  const Surface s = surface();
  expect_same_on_two_threads([&] {
    const Normals n = normals_from_point_map(s.points, s.mask);
    return std::vector<at::Tensor>{n.normals, n.valid};
  });
}

TEST(ParallelLoops, DepthEdgeMaskAndGridMesh) {
  const Surface s = surface();
  expect_same_on_two_threads([&] {
    const at::Tensor edges = depth_edge_mask(s.distance, s.mask, 0.04);
    const GridMesh mesh = grid_mesh(s.points, s.mask & ~edges & at::isfinite(s.distance));
    return std::vector<at::Tensor>{edges, mesh.vertices, mesh.pixels, mesh.faces};
  });
  // The step is found at all (the comparison above is not between two empty masks).
  EXPECT_GT(depth_edge_mask(s.distance, s.mask, 0.04).sum().item<int64_t>(), kHeight);
}

TEST(ParallelLoops, ColorizeDepth) {
  const Surface s = surface();
  expect_same_on_two_threads(
      [&] { return std::vector<at::Tensor>{colorize_depth(s.distance, s.mask)}; });
}

TEST(ParallelLoops, RasterizeNearestKeepsTheNearestOfDuplicates) {
  // 4 images of 200,000 points each onto 64 x 48 pixels: many points per pixel.
  at::manual_seed(5);
  const at::Tensor pixels = at::rand({4, 200000, 2}) * at::tensor({70.0f, 52.0f}) - 3;
  const at::Tensor distance = at::rand({4, 200000}) * 10 - 0.5;
  const at::Tensor value = at::rand({4, 200000});
  const at::Tensor valid = at::rand({4, 200000}) < 0.9;
  expect_same_on_two_threads([&] {
    const SparseDepth map = rasterize_nearest(pixels, distance, value, valid, 64, 48);
    return std::vector<at::Tensor>{map.depth, map.valid};
  });
}

}  // namespace
}  // namespace omnipoint::geometry
