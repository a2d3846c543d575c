// omnipoint forward: runs a network on an already-loaded image array and writes its raw
// outputs as .npy files named after them (docs/DESIGN.md).
#include <ATen/ATen.h>
#include <CLI/CLI.hpp>

#include <filesystem>
#include <memory>
#include <stdexcept>
#include <string>

#include "cli/commands.h"
#include "cli/device.h"
#include "cli/download_report.h"
#include "cli/threads.h"
#include "omnipoint/infer/infer.h"
#include "omnipoint/io/npy.h"

namespace omnipoint::cli {

namespace {

struct ForwardOptions {
  std::string model_path;
  std::string input_path;
  std::string out_dir;
  int64_t num_tokens = 0;  // 0: the model's default
  std::string precision = "auto";
  int threads = 0;  // 0: every core
};

// The image as a float32 (B,3,H,W) tensor in [0,1]; std::invalid_argument otherwise.
at::Tensor read_image_array(const std::string& path) {
  const at::Tensor array = io::read_npy(path);
  if (array.dim() != 4 || array.size(1) != 3 || array.size(2) < 1 || array.size(3) < 1 ||
      array.size(0) < 1)
    throw std::invalid_argument("input " + path + ": expected an array of shape (B,3,H,W), got " +
                                c10::str(array.sizes()));
  if (!at::isFloatingType(array.scalar_type()))
    throw std::invalid_argument("input " + path +
                                ": expected float32 RGB values in [0,1], got dtype " +
                                std::string(c10::toString(array.scalar_type())));
  at::Tensor image = array.to(at::kFloat);
  if (!at::isfinite(image).all().item<bool>() || image.min().item<float>() < 0 ||
      image.max().item<float>() > 1)
    throw std::invalid_argument("input " + path +
                                ": values must be finite and in [0,1] (RGB), got [" +
                                std::to_string(image.min().item<float>()) + ", " +
                                std::to_string(image.max().item<float>()) + "]");
  return image;
}

void run_forward(const ForwardOptions& options) {
  const model::Precision precision = parse_precision(options.precision, at::kCPU);
  const at::Tensor image = read_image_array(options.input_path);
  const infer::RawOutput output = infer::forward(
      infer::load_network(resolve_model(options.model_path)), image, options.num_tokens, precision);

  std::filesystem::create_directories(options.out_dir);
  const auto write = [&](const std::string& name, const at::Tensor& tensor) {
    if (tensor.defined())
      io::write_npy((std::filesystem::path(options.out_dir) / (name + ".npy")).string(), tensor);
  };
  write("points", output.points);
  write("mask", output.mask);
  write("metric_scale", output.metric_scale);
  write("rays", output.rays);
  write("distance", output.distance);
  write("normal", output.normal);
}

}  // namespace

void add_forward_command(CLI::App& app) {
  auto options = std::make_shared<ForwardOptions>();
  CLI::App* command = app.add_subcommand(
      "forward",
      "Run the network on a float32 image array (B,3,H,W, RGB in [0,1]) and write its raw outputs "
      "(points, mask, metric_scale, rays, distance, normal where the model has it) as .npy files");
  command
      ->add_option("--model", options->model_path,
                   "Weights file (.safetensors or PyTorch .pt, MoGe-2 or OmniPoint), or a "
                   "published checkpoint: hf:OWNER/REPO[/FILE][@REVISION] or a short name "
                   "(omnipoint models)")
      ->required();
  command->add_option("--input", options->input_path, "Image array (.npy, float32, B×3×H×W)")
      ->required();
  CLI::Option* num_tokens = command->add_option(
      "--num-tokens", options->num_tokens,
      "Target number of ViT patch tokens (default: the top of the model's num_tokens_range)");
  command->add_option("--out", options->out_dir, "Output folder (created if missing)")->required();
  command->add_option("--precision", options->precision, kPrecisionHelp)->capture_default_str();
  add_threads_option(command, &options->threads);
  command->callback([options, num_tokens] {
    if (num_tokens->count() > 0 && options->num_tokens <= 0)
      throw std::invalid_argument("--num-tokens must be a positive integer, got " +
                                  std::to_string(options->num_tokens));
    use_threads(options->threads);
    run_forward(*options);
  });
}

}  // namespace omnipoint::cli
