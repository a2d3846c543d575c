#pragma once
// The files of one prediction (the per-image folder of `omnipoint predict`):
//   points.ply      binary PLY, coloured, valid points only (metres, camera frame)
//   points.glb      the same cloud as a glTF 2.0 binary POINTS primitive (io/glb.h)
//   points.npy      (H, W, 3) float32 metric points, 0 where invalid (the PLY's source; the
//                   point map `omnipoint eval` scores)
//   distance.npy    (H, W) float32 metric radial distance, 0 where invalid
//   depth.npy       (H, W) float32 planar depth z, 0 where invalid
//   rays.npy        (H, W, 3) float32 unit rays
//   mask.png        8-bit, 255 = valid
//   depth.png       16-bit planar depth in millimetres (0 = invalid or behind the camera;
//                   clamped at 65.535 m)
//   depth_vis.png   colour-mapped inverse depth (distance, so panoramas colour too)
//   preview.png     the cloud from an oblique viewpoint (preview.h)
//   camera.json     the camera (JSON "camera", "camera_spec" MODEL W H PARAMS, "cameras_txt_line"
//                   1 MODEL W H PARAMS, fields of view; "camera_source" given|fitted and, when
//                   fitted, "fit_residual_deg" median/max), metric scale, alignment, notes and
//                   per-stage timing (writing included); `--camera camera.json` reads it back
//   cameras.txt     the camera as a COLMAP cameras.txt (camera id 1), when there is one
// The folder appears complete or not at all: everything is written into a temporary sibling
// folder which is then renamed over `folder` (an older folder of that name is replaced).
#include <ATen/core/Tensor.h>

#include <string>

#include "omnipoint/predict/predictor.h"

namespace omnipoint::predict {

// image (H, W, 3) RGB in [0, 1] (float) or uint8, the image the prediction was made from.
// Returns the milliseconds spent writing.
double write_prediction_outputs(const std::string& folder, const at::Tensor& image,
                                const Prediction& prediction);

// camera.json's content (without the writing time).
std::string prediction_summary_json(const Prediction& prediction);

}  // namespace omnipoint::predict
