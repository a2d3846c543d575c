#pragma once
// A2P teachers from the models that load here (a2p.h `Teacher`): the prediction for one
// pinhole view, as rays, distances along them and a confidence mask.
// - OmniPoint: metric distance ŝ·d̂ along r̂, confident where the mask head > 0.5; the
//   view's exact ray map is given as the intrinsics condition when `use_intrinsics`.
// - MoGe-2: MoGe's infer() (focal/shift recovery, metric scale when the model has the head),
//   confident where its mask holds and the geometry is finite.
#include <cstdint>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/omnipoint_model.h"

namespace omnipoint::infer {

augment::Teacher omnipoint_teacher(model::OmniPointModel model, int64_t num_tokens,
                                   bool use_intrinsics = true);
augment::Teacher moge2_teacher(model::MoGe2Model model, int64_t num_tokens);

}  // namespace omnipoint::infer
