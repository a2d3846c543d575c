// The model layer's configuration tables (model/config_tables.h): what our checkpoints carry is
// written byte for byte as before, every table reads back what it writes, MoGe-2's published
// forms still load, and errors name the key path.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <functional>
#include <string>

#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/config_tables.h"
#include "support/tiny_omnipoint.h"

namespace omnipoint::model {
namespace {

using nlohmann::json;

json moge2_fixture_config() {
  const io::SafetensorsFile file = io::read_safetensors(std::string(OMNIPOINT_FIXTURE_DIR) +
                                                        "/moge2_forward_a/model.safetensors");
  return json::parse(file.metadata.at("config"));
}

template <typename T>
json write(const util::ConfigTable<T>& table, const T& value) {
  json out;
  table.write(value, out);
  return out;
}

// read -> write -> read -> write gives the same JSON.
template <typename T>
void expect_round_trip(const util::ConfigTable<T>& table, const json& text) {
  const json written = write(table, util::read_config(table, text, "round trip"));
  EXPECT_EQ(write(table, util::read_config(table, written, "round trip")).dump(), written.dump());
}

template <typename Read>
std::string error_of(Read read) {
  try {
    read();
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

// The config the bundled model carries, written by the writer before the field tables, comes
// out of them unchanged, byte for byte.
TEST(ModelConfig, TheBundledCheckpointsConfigIsWrittenByteForByte) {
  const io::SafetensorsFile file = io::read_safetensors(std::string(OMNIPOINT_SOURCE_DIR) +
                                                        "/models/omnipoint_default.safetensors");
  const OmniPointConfig config = config_from_metadata(file.metadata);
  EXPECT_EQ(config.to_json_text(), file.metadata.at("config"));
  EXPECT_EQ(omnipoint_metadata(config), file.metadata);
  EXPECT_EQ(config.encoder.backbone_config.embed_dim, 192);
  EXPECT_EQ(config.conditioning.encoder_dim, 16);
}

TEST(ModelConfig, EveryTableReadsBackWhatItWrites) {
  const json ray = json::parse(test::tiny_omnipoint_config_json());
  const json xyz = json::parse(test::tiny_omnipoint_config_json("xyz"));
  expect_round_trip(omnipoint_table(), ray);
  expect_round_trip(omnipoint_table(), xyz);
  expect_round_trip(conditioning_table(), ray["conditioning"]);
  expect_round_trip(moge2_encoder_table(), ray["encoder"]);
  expect_round_trip(conv_stack_table(), ray["neck"]);
  expect_round_trip(dinov2_table(), ray["encoder"]["backbone_config"]);
  const json moge2 = moge2_fixture_config();
  expect_round_trip(moge2_table(), moge2);
  // The writer states every key, the per-level forms as lists.
  const json neck =
      write(conv_stack_table(), util::read_config(conv_stack_table(), ray["neck"], "neck"));
  EXPECT_EQ(neck["dim_out"], json::parse("[null, null, null, null, null]"));
  EXPECT_EQ(neck["dim_times_res_block_hidden"], 1);
  EXPECT_FALSE(neck.contains("activation"));
  const json written = write(moge2_table(), MoGe2Config::from_json(moge2));
  EXPECT_TRUE(written["normal_head"].is_null());
  EXPECT_EQ(written["scale_head"], moge2["scale_head"]);
  EXPECT_EQ(written["encoder"]["intermediate_layers"], moge2["encoder"]["intermediate_layers"]);
  // Only the heads of the output kind are written.
  const json points = OmniPointConfig::from_json(xyz).to_json();
  EXPECT_TRUE(points.contains("points_head"));
  EXPECT_FALSE(points.contains("ray_head"));
}

// MoGe-2's own forms: a hub backbone with an int of intermediate layers, a null scale head,
// DINOv2's null init_values, and keys MoGe's constructors take as **deprecated_kwargs.
TEST(ModelConfig, MoGe2PublishedFormsLoad) {
  json config = moge2_fixture_config();
  config["encoder"] = {{"backbone", "dinov2_vits14"},
                       {"intermediate_layers", 4},
                       {"dim_out", 64},
                       {"num_features", 3}};
  config["scale_head"] = nullptr;
  config["normal_head"] = config["points_head"];
  config["trained_area_range"] = {250000, 500000};
  const MoGe2Config moge2 = MoGe2Config::from_json(config);
  EXPECT_EQ(moge2.encoder.intermediate_layers, (std::vector<int64_t>{8, 9, 10, 11}));
  EXPECT_EQ(moge2.encoder.backbone_config.embed_dim, 384);
  EXPECT_TRUE(moge2.scale_head_dims.empty());
  ASSERT_TRUE(moge2.normal_head);
  const json written = write(moge2_table(), moge2);
  EXPECT_TRUE(written["scale_head"].is_null());
  EXPECT_FALSE(written["encoder"].contains("backbone_config"));  // a hub name says it all
  EXPECT_FALSE(written.contains("trained_area_range"));
  expect_round_trip(moge2_table(), config);

  json vit = moge2_fixture_config()["encoder"]["backbone_config"];
  vit["init_values"] = nullptr;  // DINOv2's None: no LayerScale
  const DinoV2Config without = DinoV2Config::from_json(vit);
  EXPECT_EQ(without.init_values, 0.0);
  EXPECT_EQ(write(dinov2_table(), without)["init_values"], 0.0);
}

TEST(ModelConfig, ErrorsNameTheKeyPath) {
  const auto omnipoint = [](const std::function<void(json&)>& change) {
    json config = json::parse(test::tiny_omnipoint_config_json());
    change(config);
    return error_of([&] { OmniPointConfig::from_json(config); });
  };
  EXPECT_EQ(omnipoint([](json& c) { c["conditioning"]["encoder_dim"] = 1e300; }),
            "OmniPoint config: conditioning.encoder_dim: expected an integer in range "
            "[-9223372036854775808, 9223372036854775807], got 1e+300");
  EXPECT_EQ(omnipoint([](json& c) { c["conditioning"]["encoder_dim"] = 0; }),
            "OmniPoint config: conditioning.encoder_dim: must be positive");
  EXPECT_EQ(omnipoint([](json& c) { c["neck"]["dim_in"][0] = 17; }),
            "OmniPoint config: neck.dim_in[0]: must be encoder.dim_out + 2 (features and uv)");
  EXPECT_EQ(omnipoint([](json& c) {
              c["neck"]["num_res_blocks"] = {0, 1, 1};
            }),
            "OmniPoint config: neck.num_res_blocks: expected 5 entries (one per level) or one "
            "value for all, got 3");
  EXPECT_EQ(omnipoint([](json& c) { c["neck"]["dim_res_blocks"][1] = 1.5; }),
            "OmniPoint config: neck.dim_res_blocks[1]: expected an integer in range "
            "[-9223372036854775808, 9223372036854775807], got 1.5");
  EXPECT_EQ(omnipoint([](json& c) { c["mask_head"]["res_block_in_norm"] = "group_norm"; }),
            "OmniPoint config: mask_head.res_block_in_norm: only \"none\" is supported, got "
            "\"group_norm\"");
  EXPECT_EQ(omnipoint([](json& c) { c["mask_head"]["dim_out"][4] = 2; }),
            "OmniPoint config: mask_head.dim_out[4]: must be 1 (the head's output channels)");
  EXPECT_EQ(omnipoint([](json& c) { c["points_head"] = c["ray_head"]; }),
            "OmniPoint config: points_head: only with \"output\": \"xyz\"");
  EXPECT_EQ(omnipoint([](json& c) { c.erase("ray_head"); }),
            "OmniPoint config: ray_head: required");
  EXPECT_EQ(omnipoint([](json& c) { c["output"] = "depth"; }),
            "OmniPoint config: output: expected one of ray_distance, xyz, got \"depth\"");
  EXPECT_EQ(omnipoint([](json& c) {
              c["scale_head"]["dims"] = {16, 1};
            }),
            "OmniPoint config: scale_head.dims: must run from the ViT width (32) to 1");
  EXPECT_EQ(omnipoint([](json& c) { c["encoder"]["backbone_config"]["num_heads"] = 3; }),
            "OmniPoint config: encoder.backbone_config.embed_dim: must be a multiple of "
            "num_heads");
  EXPECT_EQ(omnipoint([](json& c) { c["scale_head"]["width"] = 3; }),
            "OmniPoint config: scale_head.width: unknown key (expected \"dims\")");

  json moge2 = moge2_fixture_config();
  moge2["encoder"]["intermediate_layers"] = 99;
  EXPECT_EQ(error_of([&] { MoGe2Config::from_json(moge2); }),
            "MoGe-2 config: encoder.intermediate_layers: expected an integer in range [1, 4], "
            "got 99");
  moge2 = moge2_fixture_config();
  moge2["encoder"]["intermediate_layers"] = {0, 2, 1};
  EXPECT_EQ(error_of([&] { MoGe2Config::from_json(moge2); }),
            "MoGe-2 config: encoder.intermediate_layers[2]: must be increasing block indices "
            "below the depth, 4");
  moge2 = moge2_fixture_config();
  moge2.erase("points_head");
  EXPECT_EQ(error_of([&] { MoGe2Config::from_json(moge2); }),
            "MoGe-2 config: points_head: required");
  moge2 = moge2_fixture_config();
  moge2["encoder"]["backbone_config"]["depth"] = 1e12;  // bounded before anything is allocated
  EXPECT_EQ(error_of([&] { MoGe2Config::from_json(moge2); }),
            "MoGe-2 config: encoder.backbone_config.depth: must lie in [1, 1024]");
}

// validate() on a config built in code runs the table's checks.
TEST(ModelConfig, ValidateRunsTheTablesChecks) {
  ConvStackConfig stack = util::read_config(
      conv_stack_table(), json::parse(test::tiny_omnipoint_config_json())["neck"], "neck");
  EXPECT_NO_THROW(stack.validate());
  stack.dim_in[0] = std::nullopt;
  EXPECT_EQ(error_of([&] { stack.validate("MoGe-2 neck"); }),
            "MoGe-2 neck: dim_in[0]: level 0 needs an input");
  stack.resamplers.pop_back();
  EXPECT_EQ(error_of([&] { stack.validate(); }),
            "conv stack: per-level lists must all have 5 entries (resamplers one fewer)");
  DinoV2Config vit = DinoV2Config::hub("dinov2_vits14");
  EXPECT_NO_THROW(vit.validate());
  vit.ffn_layer = "geglu";
  EXPECT_EQ(error_of([&] { vit.validate(); }),
            "DINOv2 config: ffn_layer: is not supported (expected mlp or swiglufused)");
}

}  // namespace
}  // namespace omnipoint::model
