#pragma once
// MoGe-2's infer(): from the affine point map of MoGe2Model::forward to metric camera-space
// geometry (fixtures README §1.7):
//   mask = p > 0.5 → focal and z-shift recovered from the points (geometry/focal_shift.h)
//   → pinhole intrinsics → depth = z + shift, mask &= depth > 0 → [force_projection: points
//   re-projected from depth] → × metric scale → [apply_mask: +inf where masked].
// The result also carries unit rays and distances (P = distance · ray), the form OmniPoint
// models produce, so downstream code treats both kinds alike.
#include <ATen/core/Tensor.h>

#include <cstdint>

#include "omnipoint/geometry/focal_shift.h"
#include "omnipoint/model/moge2.h"

namespace omnipoint::model {

struct MoGe2InferOptions {
  bool force_projection = true;  // points = depth · K⁻¹[u,v,1] instead of the shifted map
  bool apply_mask = true;        // +inf points, depth and distance where the mask is false
  geometry::FocalShiftOptions focal_shift;
};

struct MoGe2Inference {
  at::Tensor points;        // (B,H,W,3) metric (if the model has a scale head) camera-space points
  at::Tensor depth;         // (B,H,W) planar depth
  at::Tensor mask;          // (B,H,W) bool: valid pixels (mask head > 0.5, depth > 0)
  at::Tensor intrinsics;    // (B,3,3) normalised pinhole intrinsics
  at::Tensor rays;          // (B,H,W,3) unit rays of the points (before masking)
  at::Tensor distance;      // (B,H,W) ‖points‖
  at::Tensor normal;        // (B,H,W,3), zero where masked; undefined without a normal head
  at::Tensor metric_scale;  // (B); undefined without a scale head (the output is then affine)
};

// Post-processes a forward output. Without a mask head every pixel with depth > 0 is valid.
MoGe2Inference postprocess(const MoGe2Output& output, const MoGe2InferOptions& options = {});

// forward (without autograd) + postprocess.
MoGe2Inference infer(MoGe2Model& model, const at::Tensor& image, int64_t num_tokens,
                     const MoGe2InferOptions& options = {});

}  // namespace omnipoint::model
