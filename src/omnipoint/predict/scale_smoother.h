#pragma once
// `--scale`: how the metric scale of a sequence's frames follows the network's, one rule for
// `predict --sequence` (one camera's network scale per frame, sequence_predict_job.h) and
// `predict --rig --sequence` (the rig scale per frame, rig_predict_job.h).
#include <deque>
#include <string>

namespace omnipoint::predict {

enum class ScaleMode {
  kFixed,     // one scale for every frame (the job says which: sequence_predict_job.h,
              // rig_predict_job.h)
  kSmooth,    // a robust running estimate (SequenceScale)
  kPerFrame,  // each frame's own scale (as `predict` does)
};
// "fixed", "smooth", "per-frame"; parse_scale_mode throws std::invalid_argument for others.
const char* scale_mode_name(ScaleMode mode);
ScaleMode parse_scale_mode(const std::string& name);

// The running metric scale of a sequence: next() takes each frame's own scale in frame order and
// returns the scale applied to it.
//   per-frame  the frame's own.
//   fixed      `fixed_scale`, whatever the frame.
//   smooth     in log space: a frame's log scale x_t is clipped to within kSmoothClip of the
//              median of the last kSmoothWindow frames' log scales (its own included), y_t, and
//              the estimate m_t = m_{t-1} + kSmoothGain (y_t - m_{t-1}), m_0 = y_0 = x_0; the
//              applied scale is exp(m_t). One frame's jump moves the estimate by at most
//              kSmoothGain * kSmoothClip (an outlier is rejected); a lasting change moves the
//              window's median and is followed within a few frames.
// The state is a function of the scales fed so far, so replaying a finished run's recorded
// scales restores it exactly.
class SequenceScale {
 public:
  static constexpr int kSmoothWindow = 9;
  static constexpr double kSmoothClip = 0.18;  // log scale: about ±20 %
  static constexpr double kSmoothGain = 0.25;

  explicit SequenceScale(ScaleMode mode, double fixed_scale = 1.0);
  // std::invalid_argument for a scale that is not positive and finite.
  double next(double network_scale);

 private:
  ScaleMode mode_;
  double fixed_scale_;
  std::deque<double> window_;  // the last kSmoothWindow log scales
  double estimate_ = 0;        // m_t
};

}  // namespace omnipoint::predict
