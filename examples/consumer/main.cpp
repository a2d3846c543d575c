// The smallest use of the OmniPoint library: predict a folder of images (searched recursively)
// into one output folder per image, reporting progress through an observer of the job.
//   omnipoint_consumer MODEL.safetensors IMAGES OUT
// (One image in memory instead: omnipoint::Model::load(path).predict(image, options),
// omnipoint/predict/predictor.h.)
#include <exception>
#include <iostream>
#include <string>

#include "omnipoint/predict/predict_job.h"

namespace {

// One line per image on stdout, warnings and skipped images on stderr.
class PrintedProgress : public omnipoint::predict::PredictJobObserver {
 public:
  void start(const omnipoint::predict::ImageList& images) override {
    total_ = images.images.size();
  }
  void warning(const omnipoint::predict::ImageEntry& image, const std::string& text) override {
    std::cerr << "warning: " << image.path.string() << ": " << text << "\n";
  }
  void image_written(const omnipoint::predict::ImageEntry& image,
                     const omnipoint::predict::PredictedImage& predicted) override {
    std::cout << "[" << ++done_ << "/" << total_ << "] "
              << omnipoint::predict::describe(image, predicted) << "\n";
  }
  void image_failed(const omnipoint::predict::ImageEntry& image,
                    const std::string& error) override {
    std::cerr << "[" << ++done_ << "/" << total_ << "] skipped " << image.path.string() << ": "
              << error << "\n";
  }

 private:
  size_t total_ = 0;
  size_t done_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: omnipoint_consumer MODEL.safetensors IMAGES OUT\n";
    return 2;
  }
  try {
    omnipoint::predict::PredictJobOptions options;
    options.model_path = argv[1];
    options.inputs = {argv[2]};
    options.output_dir = argv[3];
    options.max_size = 32;    // the network and the outputs at most 32 pixels wide
    options.num_tokens = 12;  // a tiny token budget: this example runs on a tiny model
    PrintedProgress progress;
    const omnipoint::predict::PredictJobSummary summary =
        omnipoint::predict::PredictJob(options, &progress).Run();
    std::cout << summary.written << " of " << summary.images << " image(s) written, "
              << summary.failed << " failed, " << summary.warnings << " warning(s)\n";
    return summary.failed == 0 && summary.written > 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "omnipoint_consumer: " << e.what() << "\n";
    return 1;
  }
}
