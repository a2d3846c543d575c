#include "omnipoint/train/training_batch.h"

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>

#include <algorithm>

#include "omnipoint/augment/p2a.h"
#include "omnipoint/augment/virtual_camera.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/camera_info.h"
#include "omnipoint/data/photometric.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/random.h"
#include "omnipoint/geometry/sparse_sampling.h"

namespace omnipoint::train {
namespace {

// P2A: the sample seen through a random virtual fisheye or panorama of the same size.
data::Sample perspective_to_any(const data::Sample& sample, uint64_t seed) {
  const int64_t width = sample.camera.width(), height = sample.camera.height();
  augment::VirtualCameraDistribution distribution;
  distribution.fisheye_size = std::max(width, height);
  distribution.panorama_width = 2 * std::max(width, height);
  augment::VirtualView view =
      augment::sample_virtual_view(distribution, at::make_generator<at::CPUGeneratorImpl>(seed));
  view.camera = view.camera.resized(width, height);
  const augment::P2AResult rendered =
      augment::perspective_to_any(sample.camera, sample.image, sample.distance, sample.mask, view);
  data::Sample out{rendered.camera, rendered.image.contiguous(), rendered.distance.contiguous(),
                   rendered.mask.contiguous(), sample.metric};
  out.sparse_labels = sample.sparse_labels;  // the samples that land stay samples
  return out;
}

// A2P: the sample's labels replaced by the teacher's, stitched back from one random view.
// camera_valid: where the sample's camera has rays.
data::Sample any_to_perspective(const data::Sample& sample, const at::Tensor& camera_valid,
                                const augment::Teacher& teacher, uint64_t seed) {
  augment::A2PViewDistribution distribution;
  distribution.min_size = distribution.max_size =
      std::max(sample.camera.width(), sample.camera.height());
  const augment::PerspectiveView view = augment::sample_perspective_view(
      sample.camera, distribution, at::make_generator<at::CPUGeneratorImpl>(seed));
  const augment::A2PResult result =
      augment::any_to_perspective(sample.camera, sample.image, view, teacher, camera_valid);
  return {sample.camera, sample.image, result.label.distance.to(at::kFloat).contiguous(),
          result.label.mask.contiguous(), false};
}

}  // namespace

TrainingItem make_training_item(const data::Sample& loaded, const ItemContext& context,
                                data::synth::Random& random) {
  const TrainConfig& config = *context.config;
  const bool conditions = context.conditions;
  data::Sample sample = loaded;
  camera::Rays ray_map = loaded.camera.ray_map(at::kFloat);
  const camera::CameraClass lens = camera::camera_class(loaded.camera);
  // Sparse labels (LiDAR) say nothing of the pixels between them: no sky is known there.
  bool sky_known = !loaded.sparse_labels;
  if (conditions && config.p2a && lens == camera::CameraClass::kPerspective &&
      random.chance(config.p2a_probability)) {
    sample = perspective_to_any(loaded, random.next_u64());
    ray_map = sample.camera.ray_map(at::kFloat);
    sky_known = false;
  } else if (conditions && config.a2p &&
             (!context.labelled || (lens != camera::CameraClass::kPerspective &&
                                    random.chance(config.a2p_probability)))) {
    sample = any_to_perspective(loaded, ray_map.valid, *context.teacher, random.next_u64());
    sky_known = false;
  }
  if (config.photometric)
    sample.image =
        data::photometric_augment(sample.image, data::PhotometricOptions{}, random.next_u64());
  if (config.flip && random.chance(0.5)) {
    // The mirror image of the scene through the mirrored camera: columns reversed, and the
    // rays' x negated, so that points = distance · ray stay the mirror image's geometry.
    sample.image = sample.image.flip({1}).contiguous();
    sample.distance = sample.distance.flip({1}).contiguous();
    sample.mask = sample.mask.flip({1}).contiguous();
    ray_map.rays = (ray_map.rays.flip({1}) * at::tensor({-1.0F, 1.0F, 1.0F})).contiguous();
    ray_map.valid = ray_map.valid.flip({1}).contiguous();
  }
  const int64_t width = sample.camera.width(), height = sample.camera.height();
  TrainingItem item;
  item.image = sample.image.permute({2, 0, 1});
  item.rays = ray_map.rays;
  item.distance = sample.distance;
  item.mask = sample.mask;
  item.mask_negative = sky_known ? ray_map.valid & ~sample.mask : at::zeros_like(sample.mask);
  item.metric = at::full({}, sample.metric, at::kBool);
  item.sparse = at::full({}, sample.sparse_labels, at::kBool);

  // Conditions (paper: each enabled with probability 0.9 from stage 2; sparse depth sampled
  // from the GT at 0.05–0.1 % of the pixels).
  // (An A2P item's "GT" is its pseudo-label.)
  const bool with_rays = conditions && random.chance(config.condition_probability);
  const bool with_depth = conditions && random.chance(config.condition_probability);
  item.condition_rays = with_rays ? ray_map.rays.permute({2, 0, 1}) : at::zeros({3, height, width});
  if (with_depth) {
    double ratio = random.uniform(config.sparse_ratio[0], config.sparse_ratio[1]);
    at::Generator generator = at::make_generator<at::CPUGeneratorImpl>(random.next_u64());
    if (sample.sparse_labels) {
      // The share is of the image's pixels, as on a dense item: of a sparse item's few labels
      // it takes correspondingly more (all of them at most).
      const double labelled = std::max(1.0, sample.mask.sum().item<double>());
      ratio = std::min(1.0, ratio * static_cast<double>(width * height) / labelled);
    }
    item.condition_depth =
        geometry::sample_uniform_ratio(sample.distance, sample.mask, ratio, generator).depth;
  } else {
    item.condition_depth = at::zeros({height, width});
  }
  return item;
}

TrainingBatch collate(const std::vector<TrainingItem>& items, int64_t num_tokens) {
  const auto stacked = [&](at::Tensor TrainingItem::*field) {
    std::vector<at::Tensor> parts;
    parts.reserve(items.size());
    for (const TrainingItem& item : items) parts.push_back(item.*field);
    return at::stack(parts);
  };
  TrainingBatch batch;
  batch.image = stacked(&TrainingItem::image).contiguous();
  batch.condition_rays = stacked(&TrainingItem::condition_rays).contiguous();
  batch.condition_sparse_depth = stacked(&TrainingItem::condition_depth).contiguous();
  batch.targets.rays = stacked(&TrainingItem::rays);
  batch.targets.distance = stacked(&TrainingItem::distance);
  batch.targets.mask = stacked(&TrainingItem::mask);
  batch.targets.mask_negative = stacked(&TrainingItem::mask_negative);
  batch.targets.metric = stacked(&TrainingItem::metric);
  batch.targets.sparse = stacked(&TrainingItem::sparse);
  batch.num_tokens = num_tokens;
  return batch;
}

TrainingBatch to_device(const TrainingBatch& batch, at::Device device) {
  const auto moved = [&](const at::Tensor& t) { return t.defined() ? t.to(device) : t; };
  TrainingBatch out = batch;
  out.image = moved(batch.image);
  out.condition_rays = moved(batch.condition_rays);
  out.condition_sparse_depth = moved(batch.condition_sparse_depth);
  out.targets.rays = moved(batch.targets.rays);
  out.targets.distance = moved(batch.targets.distance);
  out.targets.mask = moved(batch.targets.mask);
  out.targets.mask_negative = moved(batch.targets.mask_negative);
  out.targets.metric = moved(batch.targets.metric);
  out.targets.sparse = moved(batch.targets.sparse);
  return out;
}

}  // namespace omnipoint::train
