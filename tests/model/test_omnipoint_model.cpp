// The OmniPoint network on a tiny random config: outputs, conditioning, save/reload and
// initialisation from MoGe-2 (the weights of tests/fixtures/moge2_forward_a) and DINOv2.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <torch/nn/init.h>
#include <torch/nn/modules/conv.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/model/omnipoint_model.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/model/state_dict.h"
#include "support/tiny_omnipoint.h"

namespace omnipoint::model {
namespace {

constexpr int64_t kNumTokens = 12;  // a 3×4 grid for the 30×40 test images

OmniPointModel tiny_model(
    const std::string& output = "ray_distance",
    const std::string& conditioning = R"({"encoder_dim": 8, "splat_radius": 3})") {
  at::manual_seed(7);
  return OmniPointModel(
      OmniPointConfig::from_json_text(test::tiny_omnipoint_config_json(output, conditioning)));
}

// Gives the zero-initialised fusion layers (encoders' last conv, state embeddings) values.
void activate_conditioning(OmniPointModelImpl& model) {
  at::NoGradGuard no_grad;
  for (auto& [name, tensor] : state_dict(model)) {
    if (name.find("_encoder.fuse.") != std::string::npos ||
        name.find("_state.") != std::string::npos)
      tensor.normal_(0.0, 0.2);
  }
}

// Unit rays of a centred pinhole camera with focal f pixels, (B,3,H,W).
at::Tensor pinhole_rays(int64_t batch, int64_t height, int64_t width, double focal) {
  const at::Tensor u = (at::arange(width, at::kFloat) + 0.5 - width / 2.0) / focal;
  const at::Tensor v = (at::arange(height, at::kFloat) + 0.5 - height / 2.0) / focal;
  const auto grids = at::meshgrid({v, u}, "ij");
  at::Tensor rays = at::stack({grids[1], grids[0], at::ones_like(grids[0])}, 0);
  rays = rays / rays.norm(2, {0}, true);
  return rays.unsqueeze(0).expand({batch, 3, height, width}).contiguous();
}

// 15 random samples per item of a smooth positive distance field.
at::Tensor sparse_samples(int64_t batch, int64_t height, int64_t width) {
  const at::Tensor field = 2.0 + at::rand({batch, height, width});
  const at::Tensor keep =
      at::rand({batch, height, width}) < 15.0 / static_cast<double>(height * width);
  return at::where(keep, field, at::zeros_like(field));
}

struct Case {
  at::Tensor image = at::rand({2, 3, 30, 40});
  at::Tensor rays = pinhole_rays(2, 30, 40, 35.0);
  at::Tensor sparse = sparse_samples(2, 30, 40);
};

double max_difference(const at::Tensor& a, const at::Tensor& b) {
  return (a - b).abs().max().item<double>();
}

TEST(OmniPointModel, OutputShapesAndRanges) {
  for (const std::string output : {"ray_distance", "xyz"}) {
    SCOPED_TRACE(output);
    OmniPointModel model = tiny_model(output);
    activate_conditioning(*model);
    const Case c;
    const OmniPointOutput out = model->forward({c.image, c.rays, c.sparse}, kNumTokens);
    ASSERT_EQ(out.rays.sizes(), (at::IntArrayRef{2, 30, 40, 3}));
    ASSERT_EQ(out.distance.sizes(), (at::IntArrayRef{2, 30, 40}));
    ASSERT_EQ(out.points.sizes(), (at::IntArrayRef{2, 30, 40, 3}));
    ASSERT_EQ(out.mask.sizes(), (at::IntArrayRef{2, 30, 40}));
    ASSERT_EQ(out.mask_logits.sizes(), (at::IntArrayRef{2, 30, 40}));
    ASSERT_EQ(out.metric_scale.sizes(), (at::IntArrayRef{2}));
    EXPECT_LT(max_difference(out.rays.norm(2, {-1}), at::ones({2, 30, 40})), 1e-5);
    EXPECT_GT(out.distance.min().item<double>(), 0.0);
    EXPECT_GE(out.mask.min().item<double>(), 0.0);
    EXPECT_LE(out.mask.max().item<double>(), 1.0);
    EXPECT_GT(out.metric_scale.min().item<double>(), 0.0);
    EXPECT_TRUE(at::allclose(out.metric_scale, at::exp(out.log_metric_scale)));
    EXPECT_TRUE(at::allclose(out.mask, at::sigmoid(out.mask_logits)));
    const at::Tensor expected =
        out.metric_scale.view({2, 1, 1, 1}) * out.distance.unsqueeze(-1) * out.rays;
    EXPECT_LT(max_difference(out.points, expected), 1e-6);
    EXPECT_FALSE(out.points.isnan().any().item<bool>());
    if (output == "ray_distance") {
      ASSERT_EQ(out.ray_raw.sizes(), (at::IntArrayRef{2, 30, 40, 3}));
      EXPECT_TRUE(at::allclose(out.distance, at::exp(out.log_distance)));
      EXPECT_TRUE(at::allclose(out.rays, out.ray_raw / out.ray_raw.norm(2, {-1}, true)));
    } else {
      // MoGe's exp remap of the points head: P = (a·e^c, b·e^c, e^c) = d · r.
      const at::Tensor z = at::exp(out.points_raw.select(-1, 2));
      EXPECT_LT(max_difference(out.distance * out.rays.select(-1, 2), z), 1e-4);
      EXPECT_LT(max_difference(out.rays.select(-1, 0) / out.rays.select(-1, 2),
                               out.points_raw.select(-1, 0)),
                1e-4);
    }
  }
}

TEST(OmniPointModel, RunsInDoublePrecision) {
  OmniPointModel model = tiny_model();
  activate_conditioning(*model);
  const Case c;
  const OmniPointOutput single = model->forward({c.image, c.rays, c.sparse}, kNumTokens);
  model->to(at::kDouble);
  const OmniPointOutput twice = model->forward(
      {c.image.to(at::kDouble), c.rays.to(at::kDouble), c.sparse.to(at::kDouble)}, kNumTokens);
  EXPECT_EQ(twice.points.scalar_type(), at::kDouble);
  EXPECT_LT(max_difference(twice.points.to(at::kFloat), single.points), 1e-4);
  EXPECT_LT(max_difference(twice.mask.to(at::kFloat), single.mask), 1e-5);
}

TEST(OmniPointModel, ZeroInitialisedFusionStartsUnchanged) {
  OmniPointModel model = tiny_model();
  const Case c;
  const OmniPointOutput plain = model->forward({c.image}, kNumTokens);
  const OmniPointOutput conditioned = model->forward({c.image, c.rays, c.sparse}, kNumTokens);
  EXPECT_TRUE(at::equal(plain.points, conditioned.points));
  EXPECT_TRUE(at::equal(plain.mask, conditioned.mask));
  EXPECT_TRUE(at::equal(plain.metric_scale, conditioned.metric_scale));
}

TEST(OmniPointModel, EveryConditionChangesTheOutput) {
  OmniPointModel model = tiny_model();
  activate_conditioning(*model);
  const Case c;
  const OmniPointOutput none = model->forward({c.image}, kNumTokens);
  const OmniPointOutput intrinsics = model->forward({c.image, c.rays}, kNumTokens);
  const OmniPointOutput depth = model->forward({c.image, {}, c.sparse}, kNumTokens);
  const OmniPointOutput both = model->forward({c.image, c.rays, c.sparse}, kNumTokens);
  EXPECT_GT(max_difference(none.points, intrinsics.points), 1e-4);
  EXPECT_GT(max_difference(none.points, depth.points), 1e-4);
  EXPECT_GT(max_difference(intrinsics.points, both.points), 1e-4);
  EXPECT_GT(max_difference(depth.points, both.points), 1e-4);
  EXPECT_GT(max_difference(none.metric_scale, both.metric_scale), 1e-6);

  // Each piece on its own: the ray-map encoding, the sparse-depth encoding, and (without any
  // encoding) the state embeddings alone.
  OmniPointModel states_only = tiny_model();
  {
    at::NoGradGuard no_grad;
    states_only->intrinsics_state->weight.normal_(0.0, 0.2);
  }
  EXPECT_GT(max_difference(states_only->forward({c.image}, kNumTokens).points,
                           states_only->forward({c.image, c.rays}, kNumTokens).points),
            1e-4);

  // The Gaussian smoothing changes what the sparse-depth branch sees.
  OmniPointModel raw = tiny_model(
      "ray_distance", R"({"encoder_dim": 8, "splat_radius": 3, "gaussian_smoothing": false})");
  activate_conditioning(*raw);
  load_state_dict(*raw, state_dict(*model), LoadMode::kStrict);
  EXPECT_GT(max_difference(raw->forward({c.image, {}, c.sparse}, kNumTokens).points, depth.points),
            1e-4);
}

TEST(OmniPointModel, StateEmbeddingFollowsTheInputs) {
  OmniPointModel model = tiny_model();
  {
    at::NoGradGuard no_grad;
    model->intrinsics_state->weight.copy_(at::stack({at::full({32}, 1.0), at::full({32}, 10.0)}));
    model->depth_state->weight.copy_(at::stack({at::full({32}, 100.0), at::full({32}, 1000.0)}));
  }
  const Case c;
  at::Tensor rays = c.rays.clone();
  rays[1].zero_();  // item 1: no intrinsics
  at::Tensor sparse = c.sparse.clone();
  sparse[0].zero_();  // item 0: no sparse depth
  const TokenGrid grid = token_grid(30, 40, kNumTokens);
  const auto conditioning = model->condition_tokens({c.image, rays, sparse}, grid);
  EXPECT_TRUE(conditioning.intrinsics_present[0].item<bool>());
  EXPECT_FALSE(conditioning.intrinsics_present[1].item<bool>());
  EXPECT_FALSE(conditioning.sparse_depth_present[0].item<bool>());
  EXPECT_TRUE(conditioning.sparse_depth_present[1].item<bool>());
  // The class token carries only the state embeddings: e_K(present) + e_D(absent), and so on.
  ASSERT_EQ(conditioning.offset.sizes(), (at::IntArrayRef{2, 1 + 12, 32}));
  EXPECT_TRUE(at::equal(conditioning.offset[0][0], at::full({32}, 110.0)));
  EXPECT_TRUE(at::equal(conditioning.offset[1][0], at::full({32}, 1001.0)));

  const auto nothing = model->condition_tokens({c.image}, grid);
  EXPECT_TRUE(at::equal(nothing.offset, at::full({2, 13, 32}, 101.0)));
  const OmniPointOutput out = model->forward({c.image, rays, sparse}, kNumTokens);
  EXPECT_TRUE(at::equal(out.intrinsics_present, conditioning.intrinsics_present));
  EXPECT_TRUE(at::equal(out.sparse_depth_present, conditioning.sparse_depth_present));
}

TEST(OmniPointModel, GradientsReachTheConditioningThatWasUsed) {
  OmniPointModel model = tiny_model();
  activate_conditioning(*model);
  const Case c;
  const OmniPointOutput out = model->forward({c.image, c.rays}, kNumTokens);  // +K, no depth
  (out.log_distance.mean() + out.ray_raw.mean() + out.mask_logits.mean() +
   out.log_metric_scale.mean())
      .backward();
  EXPECT_GT(model->intrinsics_encoder->fuse->weight.grad().abs().sum().item<double>(), 0.0);
  EXPECT_GT(model->intrinsics_encoder->patchify->weight.grad().abs().sum().item<double>(), 0.0);
  const at::Tensor e_intrinsic = model->intrinsics_state->weight.grad();
  const at::Tensor e_depth = model->depth_state->weight.grad();
  EXPECT_EQ(e_intrinsic[0].abs().sum().item<double>(), 0.0);  // "absent" unused
  EXPECT_GT(e_intrinsic[1].abs().sum().item<double>(), 0.0);
  EXPECT_GT(e_depth[0].abs().sum().item<double>(), 0.0);
  EXPECT_EQ(e_depth[1].abs().sum().item<double>(), 0.0);  // "present" unused
  EXPECT_FALSE(model->sparse_depth_encoder->fuse->weight.grad().defined());
  EXPECT_GT(model->encoder->backbone->cls_token.grad().abs().sum().item<double>(), 0.0);
}

TEST(OmniPointModel, MixedBatchEqualsEachItemAlone) {
  OmniPointModel model = tiny_model();
  activate_conditioning(*model);
  const at::Tensor image = at::rand({4, 3, 30, 40});
  at::Tensor rays = pinhole_rays(4, 30, 40, 30.0);
  at::Tensor sparse = sparse_samples(4, 30, 40);
  rays[0].zero_();  // item 0: nothing; 1: rays; 2: sparse depth; 3: both
  rays[2].zero_();
  sparse[0].zero_();
  sparse[1].zero_();
  const OmniPointOutput batch = model->forward({image, rays, sparse}, kNumTokens);
  for (int64_t i = 0; i < 4; ++i) {
    SCOPED_TRACE(i);
    OmniPointInputs alone{image.narrow(0, i, 1)};
    if (i == 1 || i == 3) alone.rays = rays.narrow(0, i, 1);
    if (i >= 2) alone.sparse_depth = sparse.narrow(0, i, 1);
    const OmniPointOutput single = model->forward(alone, kNumTokens);
    EXPECT_LT(max_difference(single.points[0], batch.points[i]), 1e-5);
    EXPECT_LT(max_difference(single.mask[0], batch.mask[i]), 1e-5);
    EXPECT_LT(max_difference(single.metric_scale[0], batch.metric_scale[i]), 1e-5);
  }
}

TEST(OmniPointModel, EveryConfigurationSavesAndReloadsBitExactly) {
  const Case c;
  for (const std::string output : {"ray_distance", "xyz"}) {
    for (const bool intrinsics : {false, true}) {
      for (const bool depth : {false, true}) {
        for (const bool states : {false, true}) {
          for (const bool smoothing : {false, true}) {
            if (!depth && !smoothing) continue;  // smoothing is a sparse-depth option
            const std::string conditioning =
                std::string(R"({"encoder_dim": 4, "intrinsics": )") +
                (intrinsics ? "true" : "false") + R"(, "sparse_depth": )" +
                (depth ? "true" : "false") + R"(, "state_embeddings": )" +
                (states ? "true" : "false") + R"(, "gaussian_smoothing": )" +
                (smoothing ? "true" : "false") + "}";
            SCOPED_TRACE(output + " " + conditioning);
            OmniPointModel model = tiny_model(output, conditioning);
            activate_conditioning(*model);
            const OmniPointInputs inputs{c.image, intrinsics ? c.rays : at::Tensor(),
                                         depth ? c.sparse : at::Tensor()};
            const OmniPointOutput before = model->forward(inputs, kNumTokens);

            const std::string bytes =
                io::encode_safetensors(state_dict(*model), omnipoint_metadata(model->config()));
            const io::SafetensorsFile file = io::parse_safetensors(bytes.data(), bytes.size());
            OmniPointModel reloaded = load_omnipoint_model(file.tensors, file.metadata);
            EXPECT_EQ(reloaded->config().to_json_text(), model->config().to_json_text());
            const auto reloaded_tensors = state_dict(*reloaded);
            for (const auto& [name, tensor] : state_dict(*model)) {
              EXPECT_TRUE(at::equal(tensor, reloaded_tensors.at(name))) << name;
            }
            const OmniPointOutput after = reloaded->forward(inputs, kNumTokens);
            EXPECT_TRUE(at::equal(before.points, after.points));
            EXPECT_TRUE(at::equal(before.rays, after.rays));
            EXPECT_TRUE(at::equal(before.mask, after.mask));
            EXPECT_TRUE(at::equal(before.metric_scale, after.metric_scale));
          }
        }
      }
    }
  }
}

TEST(OmniPointModel, SavesAsHalfPrecisionFilesAndReloads) {
  OmniPointModel model = tiny_model();
  activate_conditioning(*model);
  const std::string path =
      (std::filesystem::temp_directory_path() / "omnipoint_model_test.safetensors").string();
  for (const at::ScalarType dtype : {at::kFloat, at::kHalf, at::kBFloat16}) {
    SCOPED_TRACE(c10::toString(dtype));
    io::write_safetensors(path, state_dict(*model), omnipoint_metadata(model->config()), dtype);
    const io::SafetensorsFile file = io::read_safetensors(path);  // converted to float32
    OmniPointModel reloaded = load_omnipoint_model(file.tensors, file.metadata);
    const auto reloaded_tensors = state_dict(*reloaded);
    for (const auto& [name, tensor] : state_dict(*model)) {
      EXPECT_TRUE(at::equal(tensor.to(dtype).to(at::kFloat), reloaded_tensors.at(name))) << name;
    }
  }
  std::remove(path.c_str());
}

TEST(OmniPointModel, ConfigRoundTripsAndRejectsBadInput) {
  const OmniPointConfig config =
      OmniPointConfig::from_json_text(test::tiny_omnipoint_config_json("ray_distance", "{}"));
  EXPECT_EQ(OmniPointConfig::from_json(config.to_json()).to_json_text(), config.to_json_text());
  EXPECT_EQ(config_from_metadata(omnipoint_metadata(config)).to_json_text(), config.to_json_text());

  EXPECT_THROW(OmniPointConfig::from_json_text("{"), std::invalid_argument);
  EXPECT_THROW(OmniPointConfig::from_json_text(test::tiny_omnipoint_config_json("points", "{}")),
               std::invalid_argument);
  EXPECT_THROW(OmniPointConfig::from_json_text(
                   test::tiny_omnipoint_config_json("ray_distance", R"({"colour": true})")),
               std::invalid_argument);
  EXPECT_THROW(OmniPointConfig::from_json_text(
                   test::tiny_omnipoint_config_json("ray_distance", R"({"splat_radius": -1})")),
               std::invalid_argument);
  EXPECT_THROW(config_from_metadata({{"format", "moge2"}, {"config", config.to_json_text()}}),
               std::invalid_argument);

  OmniPointModel model(config);
  const Case c;
  EXPECT_THROW(model->forward({c.image[0]}, kNumTokens), std::invalid_argument);
  EXPECT_THROW(model->forward({c.image, c.rays.narrow(0, 0, 1)}, kNumTokens),
               std::invalid_argument);
  EXPECT_THROW(model->forward({c.image, {}, c.sparse.unsqueeze(1)}, kNumTokens),
               std::invalid_argument);
  OmniPointModel plain =
      tiny_model("ray_distance", R"({"intrinsics": false, "sparse_depth": false})");
  EXPECT_THROW(plain->forward({c.image, c.rays}, kNumTokens), std::invalid_argument);
  EXPECT_THROW(plain->forward({c.image, {}, c.sparse}, kNumTokens), std::invalid_argument);
}

// ---------------------------------------------------------------------------------------------
// Initialisation

const std::string kFixture = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a";
TEST(OmniPointInit, FromMoGe2FixtureKeepsMoGe2Features) {
  const io::SafetensorsFile file = io::read_safetensors(kFixture + "/model.safetensors");
  const MoGe2Config moge2_config = MoGe2Config::from_json_text(file.metadata.at("config"));
  MoGe2Model moge2(moge2_config);
  load_state_dict(*moge2, file.tensors, LoadMode::kStrict);

  OmniPointModel model(OmniPointConfig::from_moge2(moge2_config, OutputKind::kRayDistance));
  const InitReport report = init_from_moge2(*model, file.tensors, moge2_config);
  // Everything shared loads; the head trunks load twice (ray, distance); 4 output tensors are
  // derived; the conditioning stays zero.
  const auto count = [](const std::vector<std::string>& names, const std::string& prefix) {
    return std::count_if(names.begin(), names.end(),
                         [&](const std::string& n) { return n.rfind(prefix, 0) == 0; });
  };
  std::vector<std::string> moge2_names;
  for (const auto& [name, tensor] : file.tensors) moge2_names.push_back(name);
  for (const char* part : {"encoder.", "neck.", "mask_head.", "scale_head."}) {
    EXPECT_EQ(count(report.loaded, part), count(moge2_names, part)) << part;
  }
  EXPECT_EQ(count(report.loaded, "ray_head."), count(moge2_names, "points_head.") - 2);
  EXPECT_EQ(count(report.loaded, "distance_head."), count(moge2_names, "points_head.") - 2);
  EXPECT_EQ(report.derived.size(), 4u);
  EXPECT_EQ(count(report.kept, "intrinsics_"), 5);  // encoder convs (2 × weight, bias) + state
  EXPECT_EQ(count(report.kept, "sparse_depth_encoder."), 4);
  EXPECT_EQ(count(report.kept, "depth_state."), 1);
  EXPECT_EQ(report.kept.size(), 10u);
  EXPECT_TRUE(report.ignored.empty());

  const at::Tensor image = at::rand({1, 3, 120, 160});
  const int64_t num_tokens = 300;
  const TokenGrid grid = token_grid(120, 160, num_tokens);
  const MoGe2RawOutput reference_raw = moge2->forward_raw(image, grid);
  const MoGe2Output reference = moge2->forward(image, num_tokens);
  // With every condition given, the zero-initialised fusion leaves MoGe-2's features.
  const OmniPointInputs conditioned{image, pinhole_rays(1, 120, 160, 100.0),
                                    sparse_samples(1, 120, 160)};
  for (const OmniPointInputs& inputs : {OmniPointInputs{image}, conditioned}) {
    EXPECT_TRUE(at::equal(model->encode(inputs, grid).features, reference_raw.projected));
    const OmniPointOutput out = model->forward(inputs, num_tokens);
    EXPECT_TRUE(at::equal(out.mask, reference.mask));
    EXPECT_TRUE(at::equal(out.metric_scale, reference.metric_scale));
    // Rays are MoGe-2's ray directions; log distance is MoGe-2's log z.
    const at::Tensor moge2_rays = reference.points / reference.points.norm(2, {-1}, true);
    EXPECT_LT(max_difference(out.rays, moge2_rays), 1e-5);
    EXPECT_LT(max_difference(out.distance, reference.points.select(-1, 2)), 1e-4);
  }

  // A checkpoint that misses a shared tensor loads nothing.
  auto incomplete = file.tensors;
  incomplete.erase("neck.input_blocks.0.weight");
  OmniPointModel fresh(OmniPointConfig::from_moge2(moge2_config, OutputKind::kRayDistance));
  const at::Tensor untouched = fresh->encoder->backbone->cls_token.clone();
  EXPECT_THROW(init_from_moge2(*fresh, incomplete, moge2_config), std::runtime_error);
  EXPECT_TRUE(at::equal(fresh->encoder->backbone->cls_token, untouched));
}

TEST(OmniPointInit, FromMoGe2IntoTheXyzAblationReproducesMoGe2Points) {
  const io::SafetensorsFile file = io::read_safetensors(kFixture + "/model.safetensors");
  const MoGe2Config moge2_config = MoGe2Config::from_json_text(file.metadata.at("config"));
  MoGe2Model moge2(moge2_config);
  load_state_dict(*moge2, file.tensors, LoadMode::kStrict);
  OmniPointModel model(OmniPointConfig::from_moge2(moge2_config, OutputKind::kXyz));
  const InitReport report = init_from_moge2(*model, file.tensors, moge2_config);
  EXPECT_TRUE(report.derived.empty());
  const at::Tensor image = at::rand({1, 3, 64, 90});
  const MoGe2Output reference = moge2->forward(image, 6);
  const OmniPointOutput out = model->forward({image}, 6);
  // points = ŝ · (MoGe-2's affine points).
  EXPECT_LT(
      max_difference(out.points, reference.metric_scale.view({1, 1, 1, 1}) * reference.points),
      1e-4);
}

TEST(OmniPointInit, FromDinoV2Backbone) {
  OmniPointModel model = tiny_model();
  DinoV2 backbone(model->config().encoder.backbone_config);
  std::map<std::string, at::Tensor> bare;
  for (const auto& [name, tensor] : state_dict(*backbone)) bare[name] = at::randn_like(tensor);
  bare["head.weight"] = at::zeros({4});  // a classifier that is not ours

  const InitReport report = init_from_dinov2(*model, bare);
  const auto loaded = state_dict(*model);
  for (const auto& [name, tensor] : bare) {
    if (name == "head.weight") continue;
    EXPECT_TRUE(at::equal(loaded.at("encoder.backbone." + name), tensor)) << name;
  }
  EXPECT_EQ(report.loaded.size(), bare.size() - 1);
  EXPECT_EQ(report.ignored, std::vector<std::string>{"encoder.backbone.head.weight"});
  EXPECT_FALSE(report.kept.empty());
  EXPECT_NE(report.summary().find("loaded " + std::to_string(bare.size() - 1)), std::string::npos);

  std::map<std::string, at::Tensor> prefixed;
  for (const auto& [name, tensor] : bare) prefixed["encoder.backbone." + name] = tensor * 2;
  init_from_dinov2(*model, prefixed);
  EXPECT_TRUE(at::equal(model->encoder->backbone->cls_token, 2 * bare.at("cls_token")));

  bare["pos_embed"] = at::zeros({1, 5, 32});
  EXPECT_THROW(init_from_dinov2(*model, bare), std::runtime_error);
}

}  // namespace
}  // namespace omnipoint::model
