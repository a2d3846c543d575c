#pragma once
// Predicting the frames of one camera's video (`omnipoint predict --sequence FRAMES --out OUT`):
// the frames are the images of FRAMES in name order (image_list.h: OUT/<frame>/ as `predict`
// lays them out, outputs.h), predicted with one camera and a metric scale that follows a robust
// running estimate instead of jumping from frame to frame.
//
// The camera. A given one (`camera`) conditions every frame. Without one it is calibrated once
// from the first `calibration_frames` frames: each is predicted without a camera and fitted by
// the automatic fit (camera::fit_camera_auto); the model chosen most often among them (a tie:
// the one chosen first) is fitted to all their rays together
// (camera::fit_camera_model_to_images, started from the first of those frames' fits), reported,
// and then conditions every frame as a given camera does (camera.json: "camera_source": "given", and the sequence record below says
// "calibrated from N frames ...").
//
// The metric scale (SequenceScale, scale_smoother.h) takes each frame's network scale in frame
// order; the scale applied to a frame's outputs is its result. --scale fixed: the calibration
// frames' median network scale (with the sequence's camera). Each frame's camera.json records it
// ("metric_scale" and the record's) beside the network's own:
//   "sequence": {"frame_index", "frames", "camera", "scale_mode", "metric_scale",
//                "network_metric_scale"}
//
// Streaming and resuming. The next frame is decoded while the network runs on this one, and
// each frame's folder is written as it finishes, whole or not at all (io::StagedFolder). A
// frame whose folder holds a camera.json with the sequence record is finished: a rerun into
// the same OUT does not redo it (SequencePredictJobObserver::frame_resumed); its recorded
// network scale is fed to the running estimate in its turn, so the estimate continues exactly
// as in an uninterrupted run, and without a given camera the camera is read back from the
// first finished frame's camera.json (no calibration again).
//
//   omnipoint::predict::SequencePredictJobOptions options;
//   options.frames_dir = "video_frames";
//   options.model_path = "model.safetensors";
//   options.output_dir = "video_predictions";
//   omnipoint::predict::SequencePredictJob(options, &observer).Run();
//
// A frame that cannot be read or predicted is skipped with one error and counted
// (SequencePredictJobSummary::failed); the estimate does not see it. Errors of the whole job
// (bad options, FRAMES not a folder or without images, a bad camera, a missing model, no
// calibration frame that can be predicted, an OUT of another --scale mode) are thrown by Run()
// before any frame is written. Messages name the options by their `omnipoint predict` flags.
#include <c10/core/Device.h>

#include <cstdint>
#include <set>
#include <string>

#include "omnipoint/model/precision.h"
#include "omnipoint/predict/image_list.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predict_job.h"
#include "omnipoint/predict/scale_smoother.h"

namespace omnipoint::predict {

struct SequencePredictJobOptions {
  // Inputs.
  std::string frames_dir;          // FRAMES: the frames, in name order (image_list.h)
  std::string camera;              // every frame's camera (io::read_camera); "": calibrated
  int64_t calibration_frames = 8;  // the first frames the camera (and the fixed scale) come from
  ScaleMode scale = ScaleMode::kSmooth;  // --scale
  bool use_exif = true;                  // apply the frames' EXIF orientation
  // The network.
  std::string model_path;                                   // the checkpoint (Model::load)
  at::Device device = at::kCPU;                             // where it runs
  model::Precision precision = model::Precision::kFloat32;  // the network's precision
  int64_t max_size = 0;                 // longest image side for the network and outputs; 0: as is
  int64_t num_tokens = 0;               // ViT token budget; 0: the model's default
  double edge_rtol = kDefaultEdgeRtol;  // flying-pixel filter tolerance; 0: off
  // Outputs.
  std::string output_dir = "predictions";                       // one folder per frame below it
  std::set<std::string> output_files = default_output_files();  // outputs.h

  // std::invalid_argument with one line for an option that is invalid.
  void Check() const;
};

struct SequencePredictJobSummary {
  int64_t frames = 0;         // found
  int64_t written = 0;        // predicted and written by this run
  int64_t resumed = 0;        // finished by an earlier run, not redone
  int64_t failed = 0;         // skipped on an error
  int64_t warnings = 0;       // about the frames
  std::string camera;         // the camera's spec (MODEL W H PARAMS)
  std::string camera_origin;  // "given" or "calibrated from N frames: ..." (also when read back)
  double fixed_scale = 0;     // --scale fixed: the scale of every frame; else 0
};

// What a job reports while it runs; every hook does nothing unless overridden. Calls come from
// the thread that runs the job: start, notes, then per frame frame_started, then
// frame_resumed, or its warnings and frame_written, or frame_failed; finished.
class SequencePredictJobObserver {
 public:
  virtual ~SequencePredictJobObserver() = default;
  virtual void start(const ImageList& /*frames*/) {}
  // Something about the whole job: the camera calibrated or restored, the frames resumed.
  virtual void note(const std::string& /*text*/) {}
  virtual void frame_started(size_t /*index*/, const ImageEntry& /*frame*/) {}
  // The frame's folder was finished by an earlier run: it is not redone.
  virtual void frame_resumed(size_t /*index*/, const ImageEntry& /*frame*/,
                             double /*metric_scale*/) {}
  virtual void warning(const ImageEntry& /*frame*/, const std::string& /*text*/) {}
  // The frame's folder is written; network_scale is the network's own scale for it
  // (predicted.prediction.metric_scale is the applied one).
  virtual void frame_written(size_t /*index*/, const ImageEntry& /*frame*/,
                             const PredictedImage& /*predicted*/, double /*network_scale*/) {}
  virtual void frame_failed(size_t /*index*/, const ImageEntry& /*frame*/,
                            const std::string& /*error*/) {}
  virtual void finished(const SequencePredictJobSummary& /*summary*/) {}
};

class SequencePredictJob {
 public:
  // `observer` (may be null) must outlive Run().
  explicit SequencePredictJob(SequencePredictJobOptions options,
                              SequencePredictJobObserver* observer = nullptr);
  SequencePredictJobSummary Run();

 private:
  SequencePredictJobOptions options_;
  SequencePredictJobObserver* observer_;
};

}  // namespace omnipoint::predict
