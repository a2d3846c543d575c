// The network a training config asks for (build_model): initialisation from an OmniPoint
// checkpoint with other conditioning branches.
#include <ATen/ATen.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <array>
#include <filesystem>
#include <string>

#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_weights.h"
#include "omnipoint/model/state_dict.h"
#include "omnipoint/train/trainer.h"
#include "train/tiny_training.h"

namespace omnipoint::train {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// The conditioning ablations fine-tune one stage-1 model with other condition settings.
TEST(BuildModel, OmniPointInitCanChangeOnlyTheConditioning) {
  const std::string dir = temp_dir("init_conditioning");
  const TrainConfig base = TrainConfig::from_json(tiny_config("x"));
  const model::OmniPointModel source = tiny_model(base);
  const std::string path = dir + "/stage1.safetensors";
  io::write_safetensors(path, model::state_dict(*source),
                        model::omnipoint_metadata(source->config()));

  json config = tiny_config(dir);
  config.erase("model");
  config["init"] = {{"from", "omnipoint"}, {"path", path}};
  config["model"] = {{"conditioning",
                      {{"encoder_dim", 8},
                       {"splat_radius", 2},
                       {"state_embeddings", false},
                       {"gaussian_smoothing", false}}},
                     {"num_tokens_range", {3, 4}}};
  const model::OmniPointModel changed = build_model(TrainConfig::from_json(config));
  EXPECT_EQ(changed->config().num_tokens_range, (std::array<int64_t, 2>{3, 4}));
  EXPECT_FALSE(changed->config().conditioning.state_embeddings);
  EXPECT_FALSE(changed->config().conditioning.gaussian_smoothing);
  const auto before = model::state_dict(*source), after = model::state_dict(*changed);
  EXPECT_LT(after.size(), before.size());  // the state embeddings are gone
  for (const auto& [name, tensor] : after) {
    ASSERT_TRUE(before.count(name)) << name;
    EXPECT_TRUE(at::equal(tensor, before.at(name))) << name;
  }
  // Anything but the conditioning and the token budget is the file's, not the config's.
  config["model"]["encoder"] = tiny_model_json()["encoder"];
  EXPECT_THROW(TrainConfig::from_json(config), std::invalid_argument);
  fs::remove_all(dir);
}

}  // namespace
}  // namespace omnipoint::train
