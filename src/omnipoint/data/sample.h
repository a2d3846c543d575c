#pragma once
// The OmniPoint dataset format (docs/DATASET.md): one folder per sample holding
//   image.png | image.jpg    RGB
//   distance.npy             (H, W) float32 metres along each pixel's unit ray, or
//   depth.npy                (H, W) float32 planar depth (camera-frame z), used when
//                            distance.npy is absent (pixels with ray z ~ 0 then unusable)
//   mask.png | mask.npy      optional (H, W): valid geometry (non-zero); absent -> distance > 0
//   meta.json                {"camera": SPEC, "metric": bool, "sparse_labels": bool,
//                            "labelled": bool, ...} with the camera spec in docs/DESIGN.md's
//                            convention (COLMAP line or JSON object); "sparse_labels" (default
//                            false) and "labelled" (default true) as Sample's
// Zero distance means "no label" (sky, outside the lens); +inf is read as sky.
#include <ATen/core/Tensor.h>

#include <string>

#include "omnipoint/camera/camera.h"

namespace omnipoint::data {

struct Sample {
  camera::Camera camera;
  at::Tensor image;     // (H, W, 3) float32 RGB in [0, 1]
  at::Tensor distance;  // (H, W) float32 along the camera's unit rays, 0 where mask is false
  at::Tensor mask;      // (H, W) bool: labelled geometry
  bool metric = false;  // distances in metres (else up to an unknown scale)
  // (4, 4) float64 world-from-camera pose where the dataset has one (sequences, rigs);
  // undefined otherwise. Nothing a single-image task needs.
  at::Tensor world_from_camera = {};
  // The labels are sparse samples (LiDAR, SfM points): an unlabelled pixel is unknown, not
  // empty (not sky), and labelled pixels have few labelled neighbours. Dense labels (rendered or
  // sensor depth maps) leave it false: there an unlabelled valid pixel holds no geometry.
  bool sparse_labels = false;
  // False for an unlabelled image (the "images" format: the source of A2P self-training):
  // its distance is all 0 and its mask all false, and only a consumer that makes its own
  // labels (A2P's pseudo-labels) may use it; evaluation refuses it.
  bool labelled = true;
};

// What meta.json says: the camera and whether distances are metric ("metric": bool, false
// when absent).
struct SampleMeta {
  camera::Camera camera;
  bool metric = false;
  bool sparse_labels = false;
  bool labelled = true;
};
// meta.json's text; not JSON, no "camera", an unknown or invalid camera or a "metric",
// "sparse_labels" or "labelled" that is not a bool -> std::runtime_error naming `name`.
SampleMeta parse_sample_meta(const std::string& text, const std::string& name);

// Reads and validates a sample folder. Missing or corrupt files, sizes that disagree with
// the camera, NaN or negative distances, an unknown camera -> std::runtime_error naming the
// folder and the problem.
Sample read_sample(const std::string& folder);

// Writes image.png, distance.npy, mask.png and meta.json into `folder` (created if
// needed), each file atomically. `extra_meta` (a JSON object as text, may be empty) is
// merged into meta.json.
void write_sample(const std::string& folder, const Sample& sample,
                  const std::string& extra_meta = "");

// Checks the invariants of a Sample in memory (shapes, dtypes, finite non-negative
// distances, zero outside the mask, a labelled pixel unless the sample is unlabelled and then
// none); throws std::invalid_argument naming `what`.
void validate_sample(const Sample& sample, const std::string& what);

}  // namespace omnipoint::data
