// The OmniPoint teacher adapter: its prediction is the model's own output for the view (metric
// distance = |points|, confident = mask > 0.5), and A2P runs end to end with it.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/infer/teacher.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/moge2_infer.h"
#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/model/omnipoint_model.h"
#include "support/tiny_omnipoint.h"

namespace omnipoint::augment {
namespace {

// A tiny random OmniPoint network (tests/support/tiny_omnipoint.h).
model::OmniPointModel tiny_model() {
  at::manual_seed(7);
  model::OmniPointModel net(
      model::OmniPointConfig::from_json_text(test::tiny_omnipoint_config_json()));
  net->eval();
  return net;
}

TEST(Teacher, OmniPointTeacherReturnsTheModelsMetricDistanceAlongItsRays) {
  auto net = tiny_model();
  const PerspectiveView view = make_perspective_view(70, 20, 0, 40, 30);
  const at::Tensor image = at::rand({30, 40, 3});
  const TeacherPrediction prediction = infer::omnipoint_teacher(net, 12)(image, view.camera);
  ASSERT_EQ(prediction.distance.sizes(), at::IntArrayRef({30, 40}));
  ASSERT_EQ(prediction.rays.sizes(), at::IntArrayRef({30, 40, 3}));
  c10::InferenceMode inference;
  model::OmniPointInputs inputs;
  inputs.image = image.permute({2, 0, 1}).unsqueeze(0).contiguous();
  inputs.rays = view.camera.ray_map().rays.permute({2, 0, 1}).unsqueeze(0);
  const auto out = net->forward(inputs, 12);
  EXPECT_TRUE(at::allclose(prediction.distance, out.points.squeeze(0).norm(2, -1), 1e-5, 1e-6));
  EXPECT_TRUE(at::equal(prediction.confident, out.mask.squeeze(0) > 0.5));

  // A2P with it: the label lives inside the view's footprint only.
  const camera::Camera wide("EQUIRECTANGULAR", 64, 32, {});
  const auto result =
      any_to_perspective(wide, at::rand({32, 64, 3}), view, infer::omnipoint_teacher(net, 12));
  EXPECT_EQ(result.label.distance.sizes(), at::IntArrayRef({32, 64}));
  EXPECT_TRUE(at::isfinite(result.label.distance).all().item<bool>());
  EXPECT_LT(result.label.mask.sum().item<int64_t>(), 64 * 32 / 4);
}

TEST(Teacher, MoGe2TeacherReturnsInferDistancesWhereItsMaskHolds) {
  // The MoGe-2 architecture of the MoGe-2 parity fixture (tests/fixtures/moge2_forward_a, random weights).
  std::ifstream in(std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a/meta.json");
  const nlohmann::json meta = nlohmann::json::parse(in);
  const PerspectiveView view = make_perspective_view(60, 0, 0, 56, 42);
  const at::Tensor image = at::rand({42, 56, 3});
  // Random weights: the first seed whose network finds positive depth somewhere, so the
  // comparison below is not vacuous.
  for (int seed = 0; seed < 50; ++seed) {
    at::manual_seed(seed);
    model::MoGe2Model net(model::MoGe2Config::from_json(meta["model_config"]));
    net->eval();
    const auto reference =
        model::infer(net, image.permute({2, 0, 1}).unsqueeze(0).contiguous(), 12);
    const at::Tensor confident =
        reference.mask.squeeze(0) & at::isfinite(reference.distance.squeeze(0));
    if (!confident.any().item<bool>()) continue;
    const TeacherPrediction prediction = infer::moge2_teacher(net, 12)(image, view.camera);
    EXPECT_TRUE(at::equal(prediction.confident, confident));
    EXPECT_TRUE(at::allclose(prediction.distance.masked_select(confident),
                             reference.distance.squeeze(0).masked_select(confident)));
    EXPECT_EQ(prediction.distance.masked_select(confident.logical_not()).abs().sum().item<double>(),
              0.0);
    EXPECT_TRUE(at::isfinite(prediction.distance).all().item<bool>());
    return;
  }
  FAIL() << "no random MoGe-2 network with a non-empty mask among 50 seeds";
}

}  // namespace
}  // namespace omnipoint::augment
