#pragma once
// The configuration tables of the model layer (util/config.h), one per struct, shared by its
// readers and writers: MoGe-2's sections are also OmniPoint's. Internal to the library.
#include <cstdint>
#include <vector>

#include "omnipoint/model/conditioning.h"
#include "omnipoint/model/conv_stack.h"
#include "omnipoint/model/dinov2.h"
#include "omnipoint/model/moge2.h"
#include "omnipoint/model/omnipoint_config.h"
#include "omnipoint/util/config.h"

namespace omnipoint::model {

const util::ConfigTable<DinoV2Config>& dinov2_table();               // dinov2.cpp
const util::ConfigTable<ConvStackConfig>& conv_stack_table();        // conv_stack.cpp
const util::ConfigTable<MoGe2EncoderConfig>& moge2_encoder_table();  // moge2.cpp
const util::ConfigTable<MoGe2Config>& moge2_table();                 // moge2.cpp
const util::ConfigTable<ConditioningConfig>& conditioning_table();   // omnipoint_config.cpp
const util::ConfigTable<OmniPointConfig>& omnipoint_table();         // omnipoint_config.cpp

// MoGe's scale head, {"dims": [in, ..., 1]} (an MLP's widths); `nullable`: null is no head
// (MoGe-2's), written as null when the dims are empty.
util::ConfigCodec<std::vector<int64_t>> scale_head_codec(bool nullable);  // moge2.cpp

// Rules MoGe-2's and OmniPoint's tables share (moge2.cpp), failing at `scope`'s "neck.dim_in"
// and "scale_head.dims": the neck takes the features and the uv map at level 0 and the uv map
// alone above it (fixtures README §1.4); the scale head runs from the ViT's width to 1.
void check_neck_inputs(const MoGe2EncoderConfig& encoder, const ConvStackConfig& neck,
                       const util::ConfigScope& scope);
void check_scale_head(const std::vector<int64_t>& dims, const MoGe2EncoderConfig& encoder,
                      const util::ConfigScope& scope);

}  // namespace omnipoint::model
