// The smallest use of the OmniPoint library: load a model, predict a point cloud from an image
// with a known camera, print what came out.
//   omnipoint_consumer MODEL.safetensors
#include <ATen/ATen.h>

#include <exception>
#include <iostream>

#include "omnipoint/predict/predictor.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: omnipoint_consumer MODEL.safetensors\n";
    return 2;
  }
  try {
    const omnipoint::Model model = omnipoint::Model::load(argv[1]);
    omnipoint::PredictOptions options;
    options.camera = omnipoint::camera::parse_camera("PINHOLE 40 30 35 35 20 15");
    options.num_tokens = 12;
    const at::Tensor image = at::rand({30, 40, 3});  // (H, W, 3) RGB in [0, 1]
    const omnipoint::Prediction prediction = model.predict(image, options);
    std::cout << "points " << prediction.points.sizes() << ", valid "
              << prediction.mask.sum().item<int64_t>() << ", metric scale "
              << prediction.metric_scale << ", network " << prediction.timing.network_ms << " ms\n";
    return prediction.points.size(0) == 30 && prediction.points.size(1) == 40 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "omnipoint_consumer: " << e.what() << "\n";
    return 1;
  }
}
