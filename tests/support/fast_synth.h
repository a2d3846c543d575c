#pragma once
// Synthetic scenes as the tests render them: the geometry and the base colours, without shadow
// and ambient-occlusion rays (the labels are the same; only the shading differs).
#include "omnipoint/data/synth/synthesize.h"

namespace omnipoint::test {

inline data::synth::SynthOptions fast_synth() {
  data::synth::SynthOptions options;
  options.render.shadows = false;
  options.render.ambient_occlusion = false;
  return options;
}

}  // namespace omnipoint::test
