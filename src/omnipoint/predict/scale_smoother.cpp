#include "omnipoint/predict/scale_smoother.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "omnipoint/predict/median.h"

namespace omnipoint::predict {

const char* scale_mode_name(ScaleMode mode) {
  switch (mode) {
    case ScaleMode::kFixed:
      return "fixed";
    case ScaleMode::kSmooth:
      return "smooth";
    case ScaleMode::kPerFrame:
      break;
  }
  return "per-frame";
}

ScaleMode parse_scale_mode(const std::string& name) {
  for (const ScaleMode mode : {ScaleMode::kFixed, ScaleMode::kSmooth, ScaleMode::kPerFrame})
    if (name == scale_mode_name(mode)) return mode;
  throw std::invalid_argument("--scale " + name + ": expected fixed, smooth or per-frame");
}

SequenceScale::SequenceScale(ScaleMode mode, double fixed_scale)
    : mode_(mode), fixed_scale_(fixed_scale) {
  if (!(fixed_scale > 0) || !std::isfinite(fixed_scale))
    throw std::invalid_argument("SequenceScale: expected a positive fixed scale");
}

double SequenceScale::next(double network_scale) {
  if (!(network_scale > 0) || !std::isfinite(network_scale))
    throw std::invalid_argument("the network's metric scale " + std::to_string(network_scale) +
                                " is not a positive number");
  if (mode_ == ScaleMode::kPerFrame) return network_scale;
  if (mode_ == ScaleMode::kFixed) return fixed_scale_;
  const double x = std::log(network_scale);
  window_.push_back(x);
  if (window_.size() > static_cast<size_t>(kSmoothWindow)) window_.pop_front();
  const double centre = median({window_.begin(), window_.end()});
  const double y = std::clamp(x, centre - kSmoothClip, centre + kSmoothClip);
  estimate_ = window_.size() == 1 ? y : estimate_ + kSmoothGain * (y - estimate_);
  return std::exp(estimate_);
}

}  // namespace omnipoint::predict
