#pragma once
// The tiny OmniPoint network the unit tests share: a ViT of width 32 with 2 blocks (patch 14,
// intermediate layers 0 and 1), MoGe-2 neck and heads of 16/8/8/8/4 channels. `output` is
// "ray_distance" or "xyz" (anything else is passed through, for the config's error tests);
// `conditioning` is the "conditioning" object as JSON text.
#include <string>

namespace omnipoint::test {

inline std::string tiny_omnipoint_config_json(
    const std::string& output = "ray_distance",
    const std::string& conditioning = R"({"encoder_dim": 8, "splat_radius": 3})") {
  const std::string stack =
      R"("dim_res_blocks": [16, 8, 8, 8, 4], "num_res_blocks": [0, 1, 1, 1, 0],
         "resamplers": ["conv_transpose", "conv_transpose", "conv_transpose", "bilinear"],
         "res_block_in_norm": "none", "res_block_hidden_norm": "none")";
  const auto head = [&](int channels) {
    return R"({"dim_in": [16, 8, 8, 8, 4], "dim_out": [null, null, null, null, )" +
           std::to_string(channels) + "], " + stack + "}";
  };
  std::string json = R"({
    "encoder": {"backbone": "dinov2_custom", "intermediate_layers": [0, 1], "dim_out": 16,
                "backbone_config": {"embed_dim": 32, "depth": 2, "num_heads": 2, "img_size": 56}},
    "neck": {"dim_in": [18, 2, 2, 2, 2], "dim_out": null, )" +
                     stack + R"(},
    "mask_head": )" + head(1) +
                     R"(,
    "scale_head": {"dims": [32, 16, 1]},
    "output": ")" + output +
                     R"(",
    "conditioning": )" +
                     conditioning;
  json += output == "xyz"
              ? R"(, "points_head": )" + head(3) + "}"
              : R"(, "ray_head": )" + head(3) + R"(, "distance_head": )" + head(1) + "}";
  return json;
}

}  // namespace omnipoint::test
