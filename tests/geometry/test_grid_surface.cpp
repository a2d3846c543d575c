// Depth edges (flying pixels) and the grid triangulation of a point map, on hand-made maps.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "omnipoint/geometry/grid_surface.h"

namespace omnipoint::geometry {
namespace {

// A 6x8 distance map: 2 m in columns 0..3, 3 m in columns 4..7.
at::Tensor step_distance() {
  at::Tensor distance = at::full({6, 8}, 2.0);
  distance.slice(1, 4).fill_(3.0);
  return distance;
}

at::Tensor columns(std::initializer_list<int64_t> cols, int64_t height = 6, int64_t width = 8) {
  at::Tensor mask = at::zeros({height, width}, at::kBool);
  for (const int64_t c : cols) mask.select(1, c).fill_(true);
  return mask;
}

TEST(DepthEdges, TheStepIsRemovedAndTheFlatAreasKept) {
  const at::Tensor distance = step_distance();
  // Both sides of the step see a 1 m range: 1/2 relative on the near side, 1/3 on the far.
  EXPECT_TRUE(at::equal(depth_edge_mask(distance, {}, 0.04), columns({3, 4})));
  EXPECT_TRUE(at::equal(depth_edge_mask(distance, {}, 0.4), columns({3})));
  EXPECT_FALSE(depth_edge_mask(distance, {}, 0.6).any().item<bool>());
  // rtol 0: off.
  EXPECT_FALSE(depth_edge_mask(distance, {}, 0).any().item<bool>());
  // Batched and float64 give the same.
  const at::Tensor batch = distance.to(at::kDouble).unsqueeze(0).expand({2, 6, 8});
  EXPECT_TRUE(at::equal(depth_edge_mask(batch, {}, 0.04), columns({3, 4}).expand({2, 6, 8})));
}

TEST(DepthEdges, InvalidPixelsNeitherAreNorMakeEdges) {
  at::Tensor distance = step_distance();
  // Columns 4..7 outside the mask (any value there), column 0 zero (invalid too).
  const at::Tensor mask = ~columns({4, 5, 6, 7});
  distance.select(1, 0).fill_(0.0);
  EXPECT_FALSE(depth_edge_mask(distance, mask, 0.04).any().item<bool>());
  // A slope of 1 % per pixel is no edge; a single spike is an edge with its 8 neighbours.
  at::Tensor slope = 2.0 + 0.02 * at::arange(8, at::kFloat).expand({6, 8});
  EXPECT_FALSE(depth_edge_mask(slope, {}, 0.04).any().item<bool>());
  slope.index_put_({2, 3}, 5.0);
  const at::Tensor edges = depth_edge_mask(slope, {}, 0.04);
  EXPECT_EQ(edges.sum().item<int64_t>(), 9);
  EXPECT_TRUE(edges.slice(0, 1, 4).slice(1, 2, 5).all().item<bool>());
}

TEST(DepthEdges, BadInputsSaySo) {
  try {
    depth_edge_mask(at::zeros({4, 4}, at::kInt), {}, 0.04);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("floating"), std::string::npos) << e.what();
  }
  try {
    depth_edge_mask(at::zeros({4, 4}), at::ones({4, 5}, at::kBool), 0.04);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("mask"), std::string::npos) << e.what();
  }
}

// A fronto-parallel plane z = 2 over the grid, x = column, y = row.
at::Tensor frontal_points(int64_t height, int64_t width) {
  const at::Tensor rows = at::arange(height, at::kFloat).view({-1, 1}).expand({height, width});
  const at::Tensor cols = at::arange(width, at::kFloat).view({1, -1}).expand({height, width});
  return at::stack({cols, rows, at::full({height, width}, 2.0f)}, -1);
}

TEST(GridMesh, TwoTrianglesPerValidCell) {
  const at::Tensor points = frontal_points(3, 4);
  const GridMesh full = grid_mesh(points, at::ones({3, 4}, at::kBool));
  EXPECT_EQ(full.faces.size(0), 2 * 2 * 3);  // 2x3 cells
  EXPECT_EQ(full.vertices.size(0), 12);
  EXPECT_EQ(full.faces.scalar_type(), at::kInt);
  EXPECT_TRUE(at::equal(full.vertices, points.reshape({-1, 3})));
  // The first cell's triangles: (0, 4, 1) and (1, 4, 5) in row-major pixel indices.
  EXPECT_TRUE(
      at::equal(full.faces.slice(0, 0, 2), at::tensor({0, 4, 1, 1, 4, 5}, at::kInt).view({2, 3})));
  // Counter-clockwise from the camera: every face normal points towards it (n · P < 0).
  const at::Tensor corners =
      full.vertices.index_select(0, full.faces.reshape({-1}).to(at::kLong)).view({-1, 3, 3});
  const at::Tensor normals = at::cross(corners.select(1, 1) - corners.select(1, 0),
                                       corners.select(1, 2) - corners.select(1, 0), -1);
  EXPECT_TRUE(((normals * corners.select(1, 0)).sum(-1) < 0).all().item<bool>());

  // An invalid interior pixel (1, 1) removes its four cells: the two cells of column 2 remain,
  // on the six pixels of columns 2 and 3.
  at::Tensor mask = at::ones({3, 4}, at::kBool);
  mask.index_put_({1, 1}, false);
  const GridMesh holed = grid_mesh(points, mask);
  EXPECT_EQ(holed.faces.size(0), 4);
  EXPECT_TRUE(at::equal(holed.pixels, at::tensor({2, 3, 6, 7, 10, 11}, at::kLong)));
  EXPECT_EQ(holed.faces.max().item<int>(), 5);
}

TEST(GridMesh, CellsAcrossADepthEdgeAreSkipped) {
  // The step between columns 3 and 4 of step_distance(): columns 3 and 4 are edges, so of the
  // 5 x 7 cells only those within columns 0..2 (2 cell columns) and 5..7 (2) remain.
  const at::Tensor distance = step_distance();
  const at::Tensor points = frontal_points(6, 8) * (distance / 2).unsqueeze(-1);
  const GridMesh connected = grid_mesh(points, at::ones({6, 8}, at::kBool));
  EXPECT_EQ(connected.faces.size(0), 2 * 5 * 7);
  const GridMesh cut = grid_mesh(points, ~depth_edge_mask(distance, {}, 0.04));
  EXPECT_EQ(cut.faces.size(0), 2 * 5 * (2 + 2));
  EXPECT_EQ(cut.vertices.size(0), 6 * (3 + 3));
  // No triangle joins the two sides.
  const at::Tensor z = cut.vertices.select(1, 2)
                           .index_select(0, cut.faces.reshape({-1}).to(at::kLong))
                           .view({-1, 3});
  EXPECT_TRUE(at::equal(std::get<0>(z.min(1)), std::get<0>(z.max(1))));
  // Too small for a cell: an empty mesh.
  EXPECT_EQ(grid_mesh(frontal_points(1, 5), at::ones({1, 5}, at::kBool)).faces.size(0), 0);
}

}  // namespace
}  // namespace omnipoint::geometry
