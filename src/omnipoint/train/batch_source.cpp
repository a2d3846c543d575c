#include "omnipoint/train/batch_source.h"
#include "omnipoint/io/camera_file.h"

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "omnipoint/augment/p2a.h"
#include "omnipoint/augment/virtual_camera.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/camera_info.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/random.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/data/transform.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/infer/teacher.h"

namespace omnipoint::train {
namespace {

constexpr uint64_t kTokenStream = 0x746f6b656e73ULL;  // separates the per-step token draw

// The largest centred window of the sample with the target aspect ratio, resized to it.
data::Sample fit_to_size(const data::Sample& sample, int64_t width, int64_t height) {
  const int64_t w = sample.camera.width(), h = sample.camera.height();
  if (w == width && h == height) return sample;
  int64_t crop_w = w, crop_h = h;
  if (w * height > h * width)
    crop_w = std::max<int64_t>(1, h * width / height);
  else
    crop_h = std::max<int64_t>(1, w * height / width);
  const data::Sample cropped =
      data::crop_sample(sample, (w - crop_w) / 2, (h - crop_h) / 2, crop_w, crop_h);
  return data::resize_sample(cropped, width, height);
}

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
  return {rendered.camera, rendered.image.contiguous(), rendered.distance.contiguous(),
          rendered.mask.contiguous(), sample.metric};
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

uint64_t derived_seed(uint64_t seed, uint64_t stream, uint64_t index) {
  return data::synth::mix64(data::synth::mix64(seed + data::synth::mix64(stream)) + index);
}

BatchSource::BatchSource(const TrainConfig& config) : config_(config) {
  namespace fs = std::filesystem;
  for (const DatasetSource& source : config_.datasets) {
    total_weight_ += source.weight;
    std::vector<std::string> folders;
    if (!source.synth) {
      std::error_code error;
      if (!fs::is_directory(source.folders, error))
        throw std::runtime_error("training data \"" + source.folders +
                                 "\": not a directory of sample folders");
      for (const fs::directory_entry& entry : fs::directory_iterator(source.folders))
        if (entry.is_directory()) folders.push_back(entry.path().string());
      if (folders.empty())
        throw std::runtime_error("training data \"" + source.folders +
                                 "\": holds no sample folders");
      std::sort(folders.begin(), folders.end());
    }
    folders_.push_back(std::move(folders));
  }
  if (config_.a2p) {
    const int64_t tokens =
        config_.a2p_teacher_tokens > 0 ? config_.a2p_teacher_tokens : config_.num_tokens[1];
    try {
      teacher_ = infer::teacher(infer::load_network(config_.a2p_teacher), tokens);
    } catch (const std::exception& error) {
      throw std::runtime_error("A2P teacher \"" + config_.a2p_teacher + "\": " + error.what());
    }
  }
}

TrainingBatch BatchSource::batch(int64_t step, bool conditions, int64_t rank, int64_t world_size,
                                 uint64_t stream) const {
  const int64_t batch_size = config_.batch_size, width = config_.width, height = config_.height;
  std::vector<at::Tensor> images, rays, distances, masks, negatives, metric, cond_rays, cond_depth;
  for (int64_t k = 0; k < batch_size; ++k) {
    const uint64_t index = static_cast<uint64_t>((step * world_size + rank) * batch_size + k);
    data::synth::Random random(derived_seed(config_.seed, stream, index), 0);

    // The data source, by weight.
    double pick = random.uniform() * total_weight_;
    size_t source = 0;
    while (source + 1 < config_.datasets.size() && pick >= config_.datasets[source].weight)
      pick -= config_.datasets[source++].weight;
    const DatasetSource& dataset = config_.datasets[source];

    const data::Sample loaded = [&] {
      if (dataset.synth) {
        const SynthSource& synth = dataset.synth_source;
        const auto kind = data::synth::parse_scene_kind(
            synth.scenes[random.integer(0, static_cast<int>(synth.scenes.size()) - 1)]);
        camera::Camera camera = io::read_camera(
            synth.cameras[random.integer(0, static_cast<int>(synth.cameras.size()) - 1)]);
        if (camera.width() != width || camera.height() != height)
          camera = camera.resized(width, height);
        return data::synth::synthesize(kind, random.next_u64(), camera).sample;
      }
      const std::vector<std::string>& folders = folders_[source];
      return fit_to_size(
          data::read_sample(folders[random.integer(0, static_cast<int>(folders.size()) - 1)]),
          width, height);
    }();
    // The augmentations draw only when enabled, so a config without them sees the same items.
    data::Sample sample = loaded;
    camera::Rays ray_map = loaded.camera.ray_map(at::kFloat);
    const camera::CameraClass lens = camera::camera_class(loaded.camera);
    bool sky_known = true;
    if (conditions && config_.p2a && lens == camera::CameraClass::kPerspective &&
        random.chance(config_.p2a_probability)) {
      sample = perspective_to_any(loaded, random.next_u64());
      ray_map = sample.camera.ray_map(at::kFloat);
      sky_known = false;
    } else if (conditions && config_.a2p && lens != camera::CameraClass::kPerspective &&
               random.chance(config_.a2p_probability)) {
      sample = any_to_perspective(loaded, ray_map.valid, teacher_, random.next_u64());
      sky_known = false;
    }
    const at::Tensor camera_valid = ray_map.valid;
    images.push_back(sample.image.permute({2, 0, 1}));
    rays.push_back(ray_map.rays);
    distances.push_back(sample.distance);
    masks.push_back(sample.mask);
    negatives.push_back(sky_known ? camera_valid & ~sample.mask : at::zeros_like(sample.mask));
    metric.push_back(at::full({}, sample.metric, at::kBool));

    // Conditions (paper: each enabled with probability 0.9 from stage 2; sparse depth sampled
    // from the GT at 0.05–0.1 % of the pixels).
    // (An A2P item's "GT" is its pseudo-label.)
    const bool with_rays = conditions && random.chance(config_.condition_probability);
    const bool with_depth = conditions && random.chance(config_.condition_probability);
    cond_rays.push_back(with_rays ? ray_map.rays.permute({2, 0, 1})
                                  : at::zeros({3, height, width}));
    if (with_depth) {
      const double ratio = random.uniform(config_.sparse_ratio[0], config_.sparse_ratio[1]);
      at::Generator generator = at::make_generator<at::CPUGeneratorImpl>(random.next_u64());
      cond_depth.push_back(
          geometry::sample_uniform_ratio(sample.distance, sample.mask, ratio, generator).depth);
    } else {
      cond_depth.push_back(at::zeros({height, width}));
    }
  }
  TrainingBatch batch;
  batch.image = at::stack(images).contiguous();
  batch.condition_rays = at::stack(cond_rays).contiguous();
  batch.condition_sparse_depth = at::stack(cond_depth).contiguous();
  batch.targets.rays = at::stack(rays);
  batch.targets.distance = at::stack(distances);
  batch.targets.mask = at::stack(masks);
  batch.targets.mask_negative = at::stack(negatives);
  batch.targets.metric = at::stack(metric);
  data::synth::Random tokens(
      derived_seed(config_.seed, stream ^ kTokenStream, static_cast<uint64_t>(step)), 0);
  batch.num_tokens = tokens.integer(static_cast<int>(config_.num_tokens[0]),
                                    static_cast<int>(config_.num_tokens[1]));
  return batch;
}

}  // namespace omnipoint::train
