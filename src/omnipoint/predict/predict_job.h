#pragma once
// Predicting a set of images into one output folder per image (`omnipoint predict`): a
// PredictJob finds the images (image_list.h), gives each its camera (a given one, a field of
// view, or its COLMAP view), its sparse depth (a file, a folder of per-image files, or its
// COLMAP points) and the network's size (max_size), predicts, writes its folder
// (outputs.h) and, with a COLMAP reconstruction, fuses every view's points into fused.ply.
// Each image is decoded once.
//
//   omnipoint::predict::PredictJobOptions options;
//   options.inputs = {"photos"};
//   options.model_path = "model.safetensors";
//   options.output_dir = "predictions";
//   const omnipoint::predict::PredictJobSummary summary =
//       omnipoint::predict::PredictJob(options, &observer).Run();
//
// An image that cannot be read or predicted (a corrupt file, a bad sparse-depth file) is
// skipped and counted (PredictJobSummary::failed); inputs that look wrong are warnings, counted
// too. Errors that concern the whole job (bad options, a missing input or model, a bad camera
// or COLMAP model) are thrown by Run() before any image is predicted. Messages name the options
// by their `omnipoint predict` flags.
#include <c10/core/Device.h>

#include <cstdint>
#include <set>
#include <string>
#include <vector>

#include "omnipoint/model/precision.h"
#include "omnipoint/predict/image_list.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predictor.h"

namespace omnipoint::predict {

struct PredictJobOptions {
  // Inputs.
  std::vector<std::string> inputs;  // image files, or folders searched recursively
  std::string camera;  // every image's camera (io::read_camera: a spec or a file); "": none
  double fov_deg = 0;  // or a pinhole centred in each image of this horizontal FoV; 0: none
  std::string colmap;  // a COLMAP sparse model folder: each image's camera, pose, sparse depth
  std::string sparse_depth;                 // a sparse depth file (inputs.h), or a folder of them
  bool sparse_depth_radial = false;         // its depth maps hold radial distance, not planar depth
  double depth_png_units_per_metre = 1000;  // depth PNG values per metre (256: KITTI)
  std::string lidar_to_camera;         // camera-from-LiDAR transform file of point clouds; "": none
  int64_t lidar_floats_per_point = 4;  // float32 values per point of .bin scans
  // A photo's EXIF data (io/exif.h; not with colmap, whose cameras are of the pixels as
  // stored): its Orientation is applied (the image as photo viewers show it; the camera and the
  // sparse depth maps given are of that image), and without camera, fov_deg or colmap its focal
  // length gives the camera (camera_from_exif). false: the pixels as stored, no EXIF camera.
  bool use_exif = true;
  // The network.
  std::string model_path;                                   // the checkpoint (Model::load)
  at::Device device = at::kCPU;                             // where it runs
  model::Precision precision = model::Precision::kFloat32;  // the network's precision
  int64_t max_size = 0;                 // longest image side for the network and outputs; 0: as is
  int64_t num_tokens = 0;               // ViT token budget; 0: the model's default
  std::string fit_model = "auto";       // the camera fitted to the rays (PredictOptions); "": none
  double edge_rtol = kDefaultEdgeRtol;  // flying-pixel filter tolerance; 0: off
  // Outputs.
  std::string output_dir = "predictions";  // one folder per image below it (image_list.h)
  std::set<std::string> output_files = default_output_files();  // outputs.h

  // std::invalid_argument with one line for an option that is invalid or conflicts with another.
  void Check() const;
};

// What one written image came to.
struct PredictedImage {
  std::string folder;               // its output folder
  camera::ImageSize original_size;  // the decoded image's
  camera::ImageSize size;           // the network's and the outputs' (max_size)
  double decode_ms = 0;             // reading and resizing the image
  double writing_ms = 0;            // writing its folder
  Prediction prediction;
};

// "IMAGE -> FOLDER (N points at WxH, metric scale S, camera SOURCE MODEL hfov H deg, network
// rays M/D deg from it, aligned xF to K sparse samples, decode D ms, network N ms, writing
// W ms)", the parts that apply: SOURCE given, exif or fitted; M/D the mean and median angle
// between the camera's rays and the network's own (Prediction::camera_agreement).
std::string describe(const ImageEntry& image, const PredictedImage& predicted);

struct PredictJobSummary {
  int64_t images = 0;        // found
  int64_t written = 0;       // output folders written
  int64_t failed = 0;        // skipped on an error
  int64_t warnings = 0;      // about the job's images
  std::string fused_cloud;   // output_dir/fused.ply when written (COLMAP), else ""
  int64_t fused_points = 0;  // its points
  int64_t fused_images = 0;  // the images they come from
};

// What a job reports while it runs; every hook does nothing unless overridden. Calls come from
// the thread that runs the job, in this order: start, notes, then per image image_started,
// its warnings and image_written or image_failed, image_done; finished.
class PredictJobObserver {
 public:
  virtual ~PredictJobObserver() = default;
  // The images are found and the model is loaded: `images` will follow.
  virtual void start(const ImageList& /*images*/) {}
  // Something about the whole job a user should know (non-image files skipped, COLMAP units).
  virtual void note(const std::string& /*text*/) {}
  virtual void image_started(size_t /*index*/, const ImageEntry& /*image*/) {}
  // An input of the image (or its prediction) looks wrong; the image is still predicted.
  virtual void warning(const ImageEntry& /*image*/, const std::string& /*text*/) {}
  // The image's folder is written (its prediction's warnings follow).
  virtual void image_written(const ImageEntry& /*image*/, const PredictedImage& /*predicted*/) {}
  // The image is skipped: `error` says why; no folder was written for it.
  virtual void image_failed(const ImageEntry& /*image*/, const std::string& /*error*/) {}
  virtual void image_done(size_t /*index*/) {}
  // The job is done (fused.ply written, if any).
  virtual void finished(const PredictJobSummary& /*summary*/) {}
};

class PredictJob {
 public:
  // `observer` (may be null) must outlive Run().
  explicit PredictJob(PredictJobOptions options, PredictJobObserver* observer = nullptr);
  // Checks the options, reads the inputs and the model, predicts every image.
  PredictJobSummary Run();

 private:
  PredictJobOptions options_;
  PredictJobObserver* observer_;
};

}  // namespace omnipoint::predict
