// End-to-end predict per image (decode -> network -> outputs) at 1,200 tokens, by stage, for a
// ViT-S and a ViT-L OmniPoint configuration with random weights; 640x480 PNG, a pinhole camera
// and 1,000 sparse-depth samples (so every stage runs). Stage times are counters in ms.
#include <ATen/ATen.h>
#include <benchmark/benchmark.h>

#include <chrono>
#include <filesystem>
#include <string>

#include "omnipoint/camera/camera.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/model/omnipoint_model.h"
#include "omnipoint/model/state_dict.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predictor.h"

namespace {

using namespace omnipoint;
namespace fs = std::filesystem;

constexpr int64_t kHeight = 480, kWidth = 640, kNumTokens = 1200;

// MoGe-2-shaped configs: the hub backbone, its four intermediate layers, decoder widths.
std::string config_json(const std::string& backbone, const std::string& layers, int64_t embed,
                        int64_t dim) {
  const std::string widths = "[" + std::to_string(dim) + ", 256, 128, 64, 32]";
  const std::string dims =
      R"("dim_res_blocks": )" + widths +
      R"(, "resamplers": ["conv_transpose", "conv_transpose", "conv_transpose", "bilinear"])";
  const auto head = [&](int channels) {
    return R"({"dim_in": )" + widths +
           R"(, "num_res_blocks": [0, 1, 1, 1, 0], "dim_out": [null, null, null, null, )" +
           std::to_string(channels) + "], " + dims + "}";
  };
  return R"({"encoder": {"backbone": ")" + backbone + R"(", "intermediate_layers": )" + layers +
         R"(, "dim_out": )" + std::to_string(dim) + R"(}, "neck": {"dim_in": [)" +
         std::to_string(dim + 2) +
         R"(, 2, 2, 2, 2], "num_res_blocks": [0, 2, 2, 2, 0], "dim_out": null, )" + dims +
         R"(}, "ray_head": )" + head(3) + R"(, "distance_head": )" + head(1) +
         R"(, "mask_head": )" + head(1) + R"(, "scale_head": {"dims": [)" + std::to_string(embed) +
         ", " + std::to_string(embed) + R"(, 1]}})";
}

std::string write_model(const std::string& name, const std::string& json) {
  const fs::path path = fs::temp_directory_path() / ("bench_predict_" + name + ".safetensors");
  const auto config = model::OmniPointConfig::from_json_text(json);
  at::manual_seed(0);
  model::OmniPointModel network(config);
  io::write_safetensors(path.string(), model::state_dict(*network),
                        model::omnipoint_metadata(config));
  return path.string();
}

double ms_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
      .count();
}

// range(0): 0 ViT-S, 1 ViT-L.
void BM_PredictEndToEnd(benchmark::State& state) {
  at::set_num_threads(2);
  const bool large = state.range(0) == 1;
  const std::string path =
      large ? write_model("vitl", config_json("dinov2_vitl14", "[4, 11, 17, 23]", 1024, 512))
            : write_model("vits", config_json("dinov2_vits14", "[2, 5, 8, 11]", 384, 384));
  const Model model = Model::load(path);
  const fs::path dir = fs::temp_directory_path() / "bench_predict";
  fs::create_directories(dir);
  at::manual_seed(1);
  io::write_image_png((dir / "image.png").string(), at::rand({kHeight, kWidth, 3}));
  PredictOptions options;
  options.num_tokens = kNumTokens;
  options.camera = camera::parse_camera("PINHOLE 640 480 500 500 320 240");
  at::Tensor sparse = at::zeros({kHeight * kWidth});
  sparse.index_put_({at::randperm(kHeight * kWidth).narrow(0, 0, 1000)},
                    1.0 + 9.0 * at::rand({1000}));
  options.sparse_depth.depth_map = sparse.view({kHeight, kWidth});

  double decode = 0, prepare = 0, network = 0, alignment = 0, fit = 0, writing = 0;
  model.predict(io::read_image((dir / "image.png").string()), options);  // warm-up
  for (auto _ : state) {
    auto start = std::chrono::steady_clock::now();
    const at::Tensor image = io::read_image((dir / "image.png").string());
    decode += ms_since(start);
    const Prediction p = model.predict(image, options);
    writing += predict::write_prediction_outputs((dir / "out").string(), image, p);
    prepare += p.timing.prepare_ms;
    network += p.timing.network_ms;
    alignment += p.timing.alignment_ms;
    fit += p.timing.camera_fit_ms;
  }
  const double n = static_cast<double>(state.iterations());
  state.counters["decode_ms"] = decode / n;
  state.counters["prepare_ms"] = prepare / n;
  state.counters["network_ms"] = network / n;
  state.counters["alignment_ms"] = alignment / n;
  state.counters["camera_fit_ms"] = fit / n;
  state.counters["writing_ms"] = writing / n;
  state.counters["post_share_of_network"] = (alignment + fit + writing) / network;
  fs::remove(path);
}
BENCHMARK(BM_PredictEndToEnd)
    ->DenseRange(0, 1)
    ->Iterations(1)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
