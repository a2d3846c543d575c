#pragma once
// A2P teachers (a2p.h `Teacher`): a network's prediction for one pinhole view through infer::run,
// as rays, metric distances along them and a confidence mask (the run's mask).
// - OmniPoint: the view's camera is given (its exact ray map as the intrinsics condition) when
//   `use_intrinsics`; the distances are ŝ·d̂.
// - MoGe-2: MoGe's infer() (focal/shift recovery, metric scale when the model has the head); the
//   camera is no input to it; distances are zero where it is not confident, as infer() masks.
#include <cstdint>

#include "omnipoint/augment/a2p.h"
#include "omnipoint/infer/infer.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/omnipoint_model.h"

namespace omnipoint::infer {

augment::Teacher teacher(const Network& network, int64_t num_tokens, bool use_intrinsics = true);
// The same on a module, on its parameters' device.
augment::Teacher omnipoint_teacher(model::OmniPointModel model, int64_t num_tokens,
                                   bool use_intrinsics = true);
augment::Teacher moge2_teacher(model::MoGe2Model model, int64_t num_tokens);

}  // namespace omnipoint::infer
