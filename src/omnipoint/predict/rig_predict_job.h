#pragma once
// Predicting the frames of a camera rig into one metric cloud per frame in the rig's body frame
// (`omnipoint predict --rig RIG.json FRAMES`, docs/RIG.md). A frame is a folder FRAMES/<frame>/
// holding one image per camera of the rig named after it (front.jpg, left.png, ...) and
// optionally a LiDAR sweep lidar.<bin|ply|pcd>; frames are the immediate subfolders of FRAMES in
// name order. For each frame every camera is predicted with its camera given and the sweep,
// taken into its frame through the rig's body_from_lidar and body_from_camera, as its sparse
// depth; then the frame gets one scale (below) and OUT/<frame>/ is written:
//   <camera>/    the usual per-camera outputs (outputs.h) in that camera's frame at its final
//                scale, and points_world.ply: its points in the body frame (camera.json records
//                the camera-from-body pose as camera_from_world)
//   fused.ply    every valid point of every camera in the body frame, coloured by its image
//                (fused.glb too when points.glb is among the outputs)
//   rig.json     the scales: {"frame", "rig_scale", "overlap_residual", "scale_rule", "lidar",
//                "missing_cameras", "fused_points", "cameras": {NAME: {"scale", "scale_source",
//                "disagreement", "applied_scale", "sparse_samples", "image",
//                "body_from_camera"}}, "overlaps": [{"camera", "sees", "pixels", "inliers",
//                "log_ratio", "residual", "spread", "sigma", "weight"}]}
// The frame's folder appears complete or not at all (io::StagedFolder). The next frame's images
// and sweep are decoded while the network runs on this one.
//
// One scale for the rig. A camera's scale is the factor that took its network distances to
// metres: the network's metric scale times the alignment to the sweep's points in its view
// ("scale_source": "lidar" when it had sweep samples). The cameras without sweep samples are
// reconciled from where their views overlap (rig_overlap.h: the same 3-D region seen by two
// cameras must come out at the same distance; LiDAR-aligned cameras are fixed anchors, a group
// of overlapping cameras without one keeps the median of its cameras' own scales, or the rig
// scale below when the frame has LiDAR-aligned cameras): "scale_source": "overlap". A camera in
// no overlap keeps the network's metric scale ("network"). The rig scale is the median of the
// cameras' scales — of the LiDAR-aligned ones when any camera has sweep samples — and a
// camera's disagreement is scale / rig scale - 1. LiDAR-aligned and overlap-reconciled cameras
// keep their own scale; every "network" camera is brought to the rig scale ("applied_scale").
// "overlap_residual" is the disagreement left over the overlaps at the final scales
// (OverlapResult::residual), null when no pair of cameras overlaps; "overlaps" lists the
// counted pairs. RigPredictJobOptions::overlap = false leaves the rule out (the median rule
// alone; the residual is still measured).
//
//   omnipoint::predict::RigPredictJobOptions options;
//   options.rig = "rig.json";
//   options.frames_dir = "frames";
//   options.model_path = "model.safetensors";
//   options.output_dir = "rig_predictions";
//   omnipoint::predict::RigPredictJob(options, &observer).Run();
//
// A sequence (`--sequence`, RigPredictJobOptions::sequence): the frames are one rig's video. The
// rule above gives each frame its own rig scale and each camera's scale relative to it; the rig
// scale then follows the sequence (SequenceScale, scale_smoother.h: fixed, smooth or per-frame,
// fed the frames' own rig scales in frame order; fixed: the first written frame's). In a frame
// without LiDAR-aligned cameras every camera's scale is multiplied by applied / own rig scale
// (the cameras keep their factors relative to the rig scale); a frame with LiDAR-aligned
// cameras has a measured rig scale and keeps it (a measured scale is not smoothed), but still
// feeds the running estimate. rig.json gains
//   "sequence": {"frame_index", "frames", "scale_mode", "rig_scale", "frame_rig_scale"}
// (the applied rig scale beside the frame's own; the top-level "rig_scale" and the cameras'
// "scale" are the applied ones). A frame whose folder holds a rig.json with that record is
// finished: a rerun into the same OUT does not redo it (RigPredictJobObserver::frame_resumed),
// and its recorded frame_rig_scale is fed to the running estimate in its turn, so the estimate
// continues exactly as in an uninterrupted run. An OUT of another --scale mode is an error.
//
// A camera without an image in a frame is a warning (the frame is predicted without it), as is
// a file of a frame folder that is neither a camera's image nor the sweep. A frame that cannot
// be predicted (none of the rig's cameras, an unreadable image, two images for one camera, a bad
// sweep) is skipped with one error and counted (RigPredictJobSummary::failed); nothing of it is
// written. Errors of the whole job (bad options, a bad rig file, no frame folder, a missing
// model) are thrown by Run() before any frame is predicted. Messages name the options by their
// `omnipoint predict` flags.
#include <ATen/core/Tensor.h>
#include <c10/core/Device.h>

#include <cstdint>
#include <functional>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "omnipoint/io/rig.h"
#include "omnipoint/model/precision.h"
#include "omnipoint/predict/outputs.h"
#include "omnipoint/predict/predictor.h"
#include "omnipoint/predict/rig_overlap.h"
#include "omnipoint/predict/scale_smoother.h"

namespace omnipoint::predict {

// One camera's image of one frame, as the job hands it to the predictor.
struct RigCameraImage {
  std::string frame;   // the frame folder's name
  std::string camera;  // the rig camera's name
  at::Tensor image;    // (H, W, 3) float32 RGB in [0, 1], at the network's size (max_size)
};

// Predicts one camera's image with the options the job gives it (the camera, the sweep as
// sparse depth): Model::predict, or another predictor (the tests' ground truth).
using RigCameraPredictor =
    std::function<Prediction(const RigCameraImage& image, const PredictOptions& options)>;

struct RigPredictJobOptions {
  // Inputs.
  std::string rig;           // the rig file (io::read_rig)
  std::string frames_dir;    // FRAMES: one subfolder per frame
  std::string lidar_format;  // the sweeps' .bin layout (--lidar-format); "": the rig's
  // The network.
  std::string model_path;                                   // the checkpoint (Model::load)
  RigCameraPredictor predictor;                             // replaces the model when set
  at::Device device = at::kCPU;                             // where the model runs
  model::Precision precision = model::Precision::kFloat32;  // the network's precision
  int64_t max_size = 0;                 // longest image side for the network and outputs; 0: as is
  int64_t num_tokens = 0;               // ViT token budget; 0: the model's default
  double edge_rtol = kDefaultEdgeRtol;  // flying-pixel filter tolerance; 0: off
  // The scales.
  bool lidar = true;    // use the frames' sweeps; false: predict as if they had none
  bool overlap = true;  // reconcile LiDAR-less cameras from their overlaps; false: median rule
  // The sequence (see the top).
  bool sequence = false;  // the frames are one rig's video: running rig scale, resume
  ScaleMode scale = ScaleMode::kSmooth;  // with sequence: how the rig scale follows the frames
  // Outputs.
  std::string output_dir = "predictions";  // OUT: one folder per frame below it
  std::set<std::string> output_files = default_output_files();  // per camera (outputs.h)

  // std::invalid_argument with one line for an option that is invalid or conflicts with another.
  void Check() const;
};

// One camera of a written frame.
struct RigCameraResult {
  std::string name;
  std::string image;         // its image file
  std::string scale_source;  // "lidar", "overlap" or "network"
  double scale = 1;          // the network's metric scale x the alignment (sweep or overlap)
  double disagreement = 0;   // scale / rig scale - 1
  double applied_scale = 1;  // the scale of its outputs (its own, or the rig scale)
  Prediction prediction;     // at applied_scale, in its camera frame
};

// One written frame.
struct RigFrameResult {
  std::string name;                        // the frame folder's name
  std::string folder;                      // OUT/<frame>
  double rig_scale = 1;                    // the median of the cameras' scales (see the top)
  double frame_rig_scale = 1;              // the frame's own; rig_scale differs with sequence
  std::optional<double> overlap_residual;  // see the top; unset when no pair overlaps
  std::vector<OverlapPair> overlaps;       // the counted pairs (indices into `cameras`)
  std::string lidar;                       // the sweep file, "" when none
  std::vector<RigCameraResult> cameras;    // in the rig's order
  std::vector<std::string> missing_cameras;
  int64_t fused_points = 0;  // fused.ply's
};

struct RigPredictJobSummary {
  int64_t frames = 0;    // found
  int64_t written = 0;   // frame folders written
  int64_t resumed = 0;   // with sequence: finished by an earlier run, not redone
  int64_t failed = 0;    // skipped on an error
  int64_t warnings = 0;  // about the frames
};

// What a job reports while it runs; every hook does nothing unless overridden. Calls come from
// the thread that runs the job, in this order: start, then per frame frame_started, then
// frame_resumed, or its warnings and frame_written, or frame_failed; frame_done; finished.
class RigPredictJobObserver {
 public:
  virtual ~RigPredictJobObserver() = default;
  // The rig is read, the frames are found and the model is loaded.
  virtual void start(const io::Rig& /*rig*/, const std::vector<std::string>& /*frames*/) {}
  virtual void frame_started(size_t /*index*/, const std::string& /*frame*/) {}
  // Something about the frame looks wrong (a camera without its image, a stray file, a
  // camera's prediction warnings); the frame is still predicted.
  virtual void warning(const std::string& /*frame*/, const std::string& /*text*/) {}
  virtual void frame_written(const RigFrameResult& /*frame*/) {}
  // With sequence: the frame's folder was finished by an earlier run (its applied rig scale);
  // it is not redone.
  virtual void frame_resumed(size_t /*index*/, const std::string& /*frame*/, double /*rig_scale*/) {
  }
  // The frame is skipped: `error` says why; nothing was written for it.
  virtual void frame_failed(const std::string& /*frame*/, const std::string& /*error*/) {}
  virtual void frame_done(size_t /*index*/) {}
  virtual void finished(const RigPredictJobSummary& /*summary*/) {}
};

class RigPredictJob {
 public:
  // `observer` (may be null) must outlive Run().
  explicit RigPredictJob(RigPredictJobOptions options, RigPredictJobObserver* observer = nullptr);
  // Checks the options, reads the rig, finds the frames, loads the model, predicts every frame.
  RigPredictJobSummary Run();

 private:
  RigPredictJobOptions options_;
  RigPredictJobObserver* observer_;
};

// "FRAME -> FOLDER (N camera(s), M points in the body frame, rig scale S, lidar FILE: NAME S
// SOURCE +D%, ...)".
std::string describe(const RigFrameResult& frame);

}  // namespace omnipoint::predict
