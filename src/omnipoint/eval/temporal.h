#pragma once
// Temporal stability of a predicted sequence (`omnipoint eval --sequence`): how much the
// distance of one static 3-D point changes between consecutive frames, with the metric scale
// as it was applied (a scale that jumps from frame to frame is what it measures; nothing is
// re-aligned per frame).
//
// For consecutive frames t, t+1 with true camera-to-world poses: every valid pixel's predicted
// point P_t (frame t's camera frame) is carried into frame t+1's camera frame through the true
// relative pose, Q = (T_{t+1}^-1 T_t) P_t, and projected through the camera into frame t+1;
// where it lands inside the image on a pixel whose four neighbours are valid in t+1, the
// predicted distance there d_{t+1} (bilinear in ‖P_{t+1}‖) is compared with the carried
// distance ‖Q‖: e = |d_{t+1} − ‖Q‖| / ‖Q‖. A pair's error is the median of e over those pixels
// (the median ignores the few that are occluded in t+1); the sequence's is the mean over the
// pairs that compared any pixel. Ground truth gives 0 up to the bilinear sampling of a curved distance map; a frame
// whose scale is k times its predecessor's gives |k − 1| (and |1/k − 1| backwards).
#include <ATen/core/Tensor.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "omnipoint/camera/camera.h"

namespace omnipoint::eval {

struct SequenceFrame {
  at::Tensor points;             // (H, W, 3) metric points in the camera frame, 0 where invalid
  at::Tensor mask;               // (H, W) bool: valid points
  at::Tensor world_from_camera;  // (4, 4) the frame's true pose (X_world = T X_camera)
};

struct PairStability {
  double error = 0;    // the median relative change (NaN when no pixel is compared)
  int64_t pixels = 0;  // the pixels compared
};

struct TemporalStability {
  double error = 0;  // the mean of the errors of the pairs that compared a pixel (else NaN)
  std::vector<PairStability> pairs;  // frame t and t+1, for t = 0 .. N−2
};

// `camera` is the frames' (at their size). std::invalid_argument for shapes that disagree.
PairStability temporal_pair_stability(const SequenceFrame& from, const SequenceFrame& to,
                                      const camera::Camera& camera);
TemporalStability temporal_stability(const std::vector<SequenceFrame>& frames,
                                     const camera::Camera& camera);

// `omnipoint eval --sequence PREDICTIONS --truth PATH`: the frames of a camera path
// (data/synth/camera_path.h: its poses and camera) as `predict --sequence PATH/frames --out
// PREDICTIONS` wrote them (PREDICTIONS/<frame>/points.npy, valid where non-zero; any size of the
// camera's aspect ratio). std::invalid_argument naming the file for a frame that is missing or
// of another shape.
TemporalStability score_predicted_sequence(const std::string& predictions,
                                           const std::string& truth);

// A rig's video: each camera of the rig scored as one camera's sequence.
struct RigTemporalStability {
  double error = 0;  // the mean of the cameras' errors that are numbers (else NaN)
  std::vector<std::pair<std::string, TemporalStability>> cameras;  // in the rig's order
};

// `omnipoint eval --sequence PREDICTIONS --truth SET` for a rig's video: the frames of
// `synth --rig --path` (SET/rig.json, SET/truth/<frame>/<camera>/ with each camera's true pose
// and camera) as `predict --rig SET/rig.json SET/frames --sequence --out PREDICTIONS` wrote them
// (PREDICTIONS/<frame>/<camera>/points.npy, in the camera's frame at the applied scale). Each
// camera's frames are scored as above through its own true poses: a rig scale that jumps moves
// every camera's distances with it, so each camera's error is the rig's stability as that camera
// sees the static scene (the fused cloud is these clouds in the body frame). A camera missing
// from a frame's truth or predictions is std::invalid_argument naming the file.
RigTemporalStability score_predicted_rig_sequence(const std::string& predictions,
                                                  const std::string& truth);
// Whether `truth` is a rendered rig's set (it holds rig.json), not a camera path.
bool is_rig_truth(const std::string& truth);

}  // namespace omnipoint::eval
