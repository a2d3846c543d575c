// Parity of the MoGe-2 network and its infer() post-processing with the reference fixture
// computed by MoGe's own code (tests/fixtures/README.md §1). Every size comes from the
// fixture's config, arrays and meta.json.
#include <ATen/ATen.h>
#include <c10/core/InferenceMode.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <fstream>
#include <string>

#include "omnipoint/geometry/view_plane_uv.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/moge2_infer.h"
#include "omnipoint/model/state_dict.h"

namespace {

using namespace omnipoint;

const std::string kFixture = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a";

nlohmann::json read_meta() {
  std::ifstream in(kFixture + "/meta.json");
  return nlohmann::json::parse(in);
}

at::Tensor expected(const std::string& name) {
  return io::read_npy(kFixture + "/" + name + ".npy");
}

// |Δ| <= 1e-4 + 1e-4·|ref| everywhere (README §1.8), same shape, infinities at the same places.
void expect_close(const at::Tensor& actual, const at::Tensor& reference, const std::string& name) {
  ASSERT_TRUE(actual.defined()) << name;
  ASSERT_EQ(actual.sizes(), reference.sizes()) << name;
  const at::Tensor a = actual.detach().to(at::kDouble).contiguous();
  const at::Tensor r = reference.to(at::kDouble);
  const at::Tensor ref_inf = at::isinf(r);
  ASSERT_TRUE(at::equal(at::isinf(a), ref_inf)) << name << ": +inf positions differ";
  ASSERT_TRUE(at::equal(a.masked_select(ref_inf), r.masked_select(ref_inf))) << name;
  const at::Tensor finite = ~ref_inf;
  const at::Tensor excess = ((a - r).abs() - (1e-4 + 1e-4 * r.abs())).masked_select(finite);
  ASSERT_FALSE(at::isnan(a.masked_select(finite)).any().item<bool>()) << name << ": NaN";
  EXPECT_LE(excess.max().item<double>(), 0.0)
      << name << ": max |Δ| " << (a - r).masked_select(finite).abs().max().item<double>();
}

class MoGe2Fixture : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    const io::SafetensorsFile file = io::read_safetensors(kFixture + "/model.safetensors");
    tensors_ = new std::map<std::string, at::Tensor>(file.tensors);
    model_ = new model::MoGe2Model(model::load_moge2(file.tensors, file.metadata));
  }
  static void TearDownTestSuite() {
    delete model_;
    delete tensors_;
  }
  static model::MoGe2Model* model_;
  static std::map<std::string, at::Tensor>* tensors_;
  c10::InferenceMode inference_;
};
model::MoGe2Model* MoGe2Fixture::model_ = nullptr;
std::map<std::string, at::Tensor>* MoGe2Fixture::tensors_ = nullptr;

TEST_F(MoGe2Fixture, StrictLoadFindsEveryTensor) {
  const nlohmann::json meta = read_meta();
  model::MoGe2Model fresh(model::MoGe2Config::from_json(meta["model_config"]));
  const model::LoadReport report =
      model::load_state_dict(*fresh, *tensors_, model::LoadMode::kStrict);
  EXPECT_TRUE(report.missing.empty());
  EXPECT_TRUE(report.unexpected.empty());
  EXPECT_TRUE(report.mismatched.empty());
  EXPECT_EQ(report.loaded.size(), meta["num_state_dict_tensors"].get<size_t>());
  int64_t parameters = 0;
  for (const auto& p : fresh->parameters()) parameters += p.numel();
  EXPECT_EQ(parameters, meta["num_parameters"].get<int64_t>());
}

// Runs the encoder step by step and compares every intermediate the fixture records in `dir`
// (features_i only where present), then the full forward.
void check_forward(model::MoGe2Model& model, const std::string& dir,
                   const nlohmann::json& case_meta) {
  const auto load = [&](const std::string& name) {
    return io::read_npy(kFixture + "/" + dir + name + ".npy");
  };
  const auto exists = [&](const std::string& name) {
    return std::ifstream(kFixture + "/" + dir + name + ".npy").good();
  };
  const at::Tensor image = load("input");
  const int64_t num_tokens = case_meta["num_tokens"].get<int64_t>();
  const model::TokenGrid grid = model::token_grid(image.size(2), image.size(3), num_tokens);
  EXPECT_EQ(grid.rows, case_meta["token_grid"]["rows"].get<int64_t>());
  EXPECT_EQ(grid.cols, case_meta["token_grid"]["cols"].get<int64_t>());

  auto& encoder = *model->encoder;
  auto& backbone = *encoder.backbone;
  expect_close(backbone.position_embedding(grid.rows, grid.cols), load("expected_pos_embed"),
               dir + "pos_embed");
  const at::Tensor tokens = backbone.prepare_tokens(encoder.preprocess(image, grid));
  expect_close(tokens, load("expected_tokens_embedded"), dir + "tokens_embedded");
  const auto layers = backbone.intermediate_layers(tokens, encoder.config().intermediate_layers);
  for (size_t i = 0; i < layers.size(); ++i) {
    const std::string name = "expected_features_" + std::to_string(i);
    if (exists(name)) expect_close(layers[i].patch_tokens, load(name), dir + name);
  }
  expect_close(layers.back().class_token, load("expected_cls"), dir + "cls");
  expect_close(encoder.project(layers, grid).features, load("expected_projected_features"),
               dir + "projected");
  if (exists("expected_raw_points"))
    expect_close(model->forward_raw(image, grid).points, load("expected_raw_points"),
                 dir + "raw_points");

  const model::MoGe2Output output = model->forward(image, num_tokens);
  expect_close(output.points, load("expected_points"), dir + "points");
  expect_close(output.mask, load("expected_mask"), dir + "mask");
  expect_close(output.metric_scale, load("expected_metric_scale"), dir + "metric_scale");
  if (exists("expected_normal"))
    expect_close(output.normal, load("expected_normal"), dir + "normal");
}

TEST_F(MoGe2Fixture, ForwardMatchesMoGe) {
  check_forward(*model_, "", read_meta());
}

TEST_F(MoGe2Fixture, AntiAliasedDownsampleCaseMatchesMoGe) {
  const nlohmann::json meta = read_meta()["extra_downsample"];
  check_forward(*model_, meta["folder"].get<std::string>() + "/", meta);
}

TEST_F(MoGe2Fixture, InferMatchesMoGe) {
  const nlohmann::json meta = read_meta();
  const at::Tensor image = expected("input");
  const model::MoGe2Output output = (*model_)->forward(image, meta["num_tokens"].get<int64_t>());

  // Our Gauss-Newton replay of scipy's LM reproduces the shift it returned.
  const at::Tensor mask = output.mask > 0.5;
  const geometry::FocalShift camera = geometry::recover_focal_shift(output.points, mask);
  const auto& infer_meta = meta["infer"];
  for (int64_t b = 0; b < image.size(0); ++b) {
    EXPECT_NEAR(camera.shift[b].item<double>(), infer_meta["shift_returned"][b].get<double>(),
                1e-6);
    EXPECT_NEAR(camera.focal[b].item<double>(), infer_meta["focal_returned"][b].get<double>(),
                1e-6);
  }

  const model::MoGe2Inference result = model::postprocess(output);
  expect_close(result.points, expected("expected_infer_points"), "infer points");
  expect_close(result.depth, expected("expected_infer_depth"), "infer depth");
  expect_close(result.intrinsics, expected("expected_infer_intrinsics"), "infer intrinsics");
  EXPECT_TRUE(at::equal(result.mask, expected("expected_infer_mask").to(at::kBool)));

  // The same geometry as rays and distances: unit rays, P = distance · ray where valid.
  const at::Tensor valid = result.mask.unsqueeze(-1).expand_as(result.points);
  EXPECT_TRUE(at::allclose(at::linalg_vector_norm(result.rays, 2, {-1}),
                           at::ones_like(result.distance), 0, 1e-5));
  EXPECT_TRUE(at::allclose((result.rays * result.distance.unsqueeze(-1)).masked_select(valid),
                           result.points.masked_select(valid), 1e-5, 1e-5));
  EXPECT_TRUE(at::equal(at::isinf(result.distance), ~result.mask));
}

TEST(FocalShift, TooFewValidSamplesGiveFocalOneShiftZero) {
  const at::Tensor points = at::rand({2, 8, 8, 3}) + 1;
  at::Tensor mask = at::zeros({2, 8, 8}, at::kBool);
  mask[1].fill_(true);
  const geometry::FocalShift camera = geometry::recover_focal_shift(points, mask);
  EXPECT_EQ(camera.focal[0].item<float>(), 1.0f);
  EXPECT_EQ(camera.shift[0].item<float>(), 0.0f);
  EXPECT_TRUE(at::isfinite(camera.focal).all().item<bool>());
  EXPECT_TRUE(at::isfinite(camera.shift).all().item<bool>());
}

TEST(FocalShift, RecoversAKnownPinholeCamera) {
  // Points of a pinhole camera with focal 1.7 (half-diagonal units), shifted in z by −0.4.
  const int64_t height = 48, width = 64;
  const at::Tensor uv =
      geometry::normalized_view_plane_uv(width, height, double(width) / height, at::kDouble);
  const at::Tensor depth = 2 + at::rand({height, width}, at::kDouble);
  const at::Tensor xy = uv * depth.unsqueeze(-1) / 1.7;
  const at::Tensor points = at::cat({xy, (depth - 0.4).unsqueeze(-1)}, -1).unsqueeze(0);
  geometry::FocalShiftOptions tight;
  tight.ftol = 1e-12;
  const geometry::FocalShift camera = geometry::recover_focal_shift(points, at::Tensor(), tight);
  EXPECT_NEAR(camera.shift.item<double>(), 0.4, 1e-6);
  EXPECT_NEAR(camera.focal.item<double>(), 1.7, 1e-6);
}

TEST(TokenGrid, RoundsHalfToEvenAndKeepsAspect) {
  EXPECT_EQ(model::token_grid(98, 203, 256).rows, 11);  // README §1.2 example: 11 × 23
  EXPECT_EQ(model::token_grid(98, 203, 256).cols, 23);
  EXPECT_EQ(model::token_grid(100, 100, 2).rows, 1);  // sqrt(2) → 1
  EXPECT_THROW(model::token_grid(100, 100, 0), std::invalid_argument);
}

TEST(MoGe2Config, RejectsUnsupportedSettingsClearly) {
  nlohmann::json config = read_meta()["model_config"];
  config["neck"]["res_block_in_norm"] = "group_norm";
  EXPECT_THROW(model::MoGe2Config::from_json(config), std::invalid_argument);
  config = read_meta()["model_config"];
  config["encoder"]["backbone"] = "resnet50";
  EXPECT_THROW(model::MoGe2Config::from_json(config), std::invalid_argument);
  config = read_meta()["model_config"];
  config["remap_output"] = "cube";
  EXPECT_THROW(model::MoGe2Config::from_json(config), std::invalid_argument);
  EXPECT_THROW(model::MoGe2Config::from_json_text("{not json"), std::invalid_argument);
  // The default token count is MoGe's infer() default: the top of num_tokens_range.
  config = read_meta()["model_config"];
  EXPECT_EQ(model::MoGe2Config::from_json(config).default_num_tokens(),
            config["num_tokens_range"][1].get<int64_t>());
  // Hub names resolve to the published ViT shapes.
  EXPECT_EQ(model::DinoV2Config::hub("dinov2_vitl14").embed_dim, 1024);
  EXPECT_EQ(model::DinoV2Config::hub("dinov2_vitg14").depth, 40);
}

}  // namespace

namespace {

// A tiny random MoGe-2 with every head, for properties the fixture (no normal head, batch 1)
// does not cover.
model::MoGe2Config tiny_config_with_normals() {
  nlohmann::json config = read_meta()["model_config"];
  config["normal_head"] = config["points_head"];
  return model::MoGe2Config::from_json(config);
}

TEST(MoGe2, BatchedForwardEqualsPerImageAndNormalsAreUnit) {
  c10::InferenceMode inference;
  model::MoGe2Model net(tiny_config_with_normals());
  net->eval();
  const at::Tensor images = at::rand({2, 3, 50, 70});
  const model::MoGe2Output batched = net->forward(images, 40);
  ASSERT_TRUE(batched.normal.defined());
  EXPECT_EQ(batched.normal.sizes(), (std::vector<int64_t>{2, 50, 70, 3}));
  EXPECT_TRUE(at::allclose(at::linalg_vector_norm(batched.normal, 2, {-1}), at::ones({2, 50, 70}),
                           0, 1e-5));
  for (int64_t b = 0; b < 2; ++b) {
    const model::MoGe2Output single = net->forward(images.narrow(0, b, 1), 40);
    EXPECT_TRUE(at::allclose(single.points, batched.points.narrow(0, b, 1), 1e-4, 1e-5));
    EXPECT_TRUE(at::allclose(single.mask, batched.mask.narrow(0, b, 1), 1e-4, 1e-5));
    EXPECT_TRUE(
        at::allclose(single.metric_scale, batched.metric_scale.narrow(0, b, 1), 1e-4, 1e-6));
  }
  const model::MoGe2Inference result = model::infer(net, images, 40);
  EXPECT_EQ(result.intrinsics.sizes(), (std::vector<int64_t>{2, 3, 3}));
  EXPECT_TRUE(at::equal(at::isinf(result.depth), ~result.mask));
  EXPECT_TRUE(at::equal(
      result.normal.masked_select(~result.mask.unsqueeze(-1).expand_as(result.normal)).abs().sum(),
      at::zeros({})));
}

}  // namespace
