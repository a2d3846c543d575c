#include "omnipoint/train/batch_source.h"

#include <ATen/ATen.h>
#include <ATen/CPUGeneratorImpl.h>

#include <algorithm>
#include <filesystem>
#include <stdexcept>

#include "omnipoint/augment/p2a.h"
#include "omnipoint/augment/virtual_camera.h"
#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/camera_info.h"
#include "omnipoint/data/photometric.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/data/synth/random.h"
#include "omnipoint/data/synth/synthesize.h"
#include "omnipoint/data/transform.h"
#include "omnipoint/geometry/sparse_sampling.h"
#include "omnipoint/infer/teacher.h"
#include "omnipoint/util/threads.h"

namespace omnipoint::train {
namespace {

constexpr uint64_t kTokenStream = 0x746f6b656e73ULL;   // separates the per-step token draw
constexpr uint64_t kBucketStream = 0x6275636b6574ULL;  // and the per-step bucket draw

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
  for (size_t i = 0; i < config_.datasets.size(); ++i) {
    const DatasetSource& source = config_.datasets[i];
    const auto same_size = [&](const Bucket& b) {
      return b.width == source.width && b.height == source.height;
    };
    auto bucket = std::find_if(buckets_.begin(), buckets_.end(), same_size);
    if (bucket == buckets_.end())
      bucket = buckets_.insert(buckets_.end(), Bucket{source.width, source.height, {}});
    bucket->sources.push_back(i);
    std::vector<std::string> folders;
    if (!source.synth) {
      std::error_code error;
      if (!fs::is_directory(source.folders, error))
        throw std::runtime_error("training data \"" + source.folders +
                                 "\": not a directory of sample folders");
      // (A ".partial" folder is a sample still being written by `omnipoint synth`.)
      for (const fs::directory_entry& entry : fs::directory_iterator(source.folders))
        if (entry.is_directory() && entry.path().extension() != ".partial")
          folders.push_back(entry.path().string());
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

double BatchSource::source_weight(size_t source, bool conditions) const {
  const DatasetSource& dataset = config_.datasets[source];
  return dataset.labelled || (conditions && config_.a2p) ? dataset.weight : 0.0;
}

double BatchSource::bucket_weight(const Bucket& bucket, bool conditions) const {
  double weight = 0;
  for (const size_t source : bucket.sources) weight += source_weight(source, conditions);
  return weight;
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
  return out;
}

TrainingBatch BatchSource::batch(int64_t step, bool conditions, int64_t rank, int64_t world_size,
                                 uint64_t stream, int64_t bucket_index) const {
  // The step's bucket: drawn by weight (one draw per step, the same on every rank), or given.
  const Bucket* bucket = nullptr;
  if (bucket_index >= 0) {
    for (size_t i = 0; i < buckets_.size() && !bucket; ++i) {
      const Bucket& candidate = buckets_[(static_cast<size_t>(bucket_index) + i) % buckets_.size()];
      if (bucket_weight(candidate, conditions) > 0) bucket = &candidate;
    }
  } else if (buckets_.size() == 1) {
    bucket = &buckets_.front();
  } else {
    double total = 0;
    for (const Bucket& b : buckets_) total += bucket_weight(b, conditions);
    data::synth::Random draw(
        derived_seed(config_.seed, stream ^ kBucketStream, static_cast<uint64_t>(step)), 0);
    double pick = draw.uniform() * total;
    for (const Bucket& b : buckets_) {
      const double weight = bucket_weight(b, conditions);
      if (weight <= 0) continue;
      bucket = &b;
      if (pick < weight) break;
      pick -= weight;
    }
  }
  if (!bucket) throw std::logic_error("training data: no source can be used in this stage");
  const double total_weight = bucket_weight(*bucket, conditions);

  const int64_t batch_size = config_.batch_size, width = bucket->width, height = bucket->height;
  struct Item {
    at::Tensor image, rays, distance, mask, negative, metric, condition_rays, condition_depth;
  };
  const auto make_item = [&](int64_t k) {
    Item item;
    const uint64_t index = static_cast<uint64_t>((step * world_size + rank) * batch_size + k);
    data::synth::Random random(derived_seed(config_.seed, stream, index), 0);

    // The data source, by weight, among the bucket's usable ones.
    double pick = random.uniform() * total_weight;
    size_t source = 0;
    for (const size_t candidate : bucket->sources) {
      const double weight = source_weight(candidate, conditions);
      if (weight <= 0) continue;
      source = candidate;  // the last usable one, should rounding leave pick >= the total
      if (pick < weight) break;
      pick -= weight;
    }
    const DatasetSource& dataset = config_.datasets[source];

    const data::Sample loaded = [&] {
      if (dataset.synth) {
        const SynthSource& synth = dataset.synth_source;
        const data::synth::SceneKind kind =
            synth.scenes[random.integer(0, static_cast<int>(synth.scenes.size()) - 1)];
        camera::Camera camera =
            synth.cameras[random.integer(0, static_cast<int>(synth.cameras.size()) - 1)];
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
    } else if (conditions && config_.a2p &&
               (!dataset.labelled || (lens != camera::CameraClass::kPerspective &&
                                      random.chance(config_.a2p_probability)))) {
      sample = any_to_perspective(loaded, ray_map.valid, teacher_, random.next_u64());
      sky_known = false;
    }
    if (config_.photometric)
      sample.image =
          data::photometric_augment(sample.image, data::PhotometricOptions{}, random.next_u64());
    if (config_.flip && random.chance(0.5)) {
      // The mirror image of the scene through the mirrored camera: columns reversed, and the
      // rays' x negated, so that points = distance · ray stay the mirror image's geometry.
      sample.image = sample.image.flip({1}).contiguous();
      sample.distance = sample.distance.flip({1}).contiguous();
      sample.mask = sample.mask.flip({1}).contiguous();
      ray_map.rays = (ray_map.rays.flip({1}) * at::tensor({-1.0F, 1.0F, 1.0F})).contiguous();
      ray_map.valid = ray_map.valid.flip({1}).contiguous();
    }
    const at::Tensor camera_valid = ray_map.valid;
    item.image = sample.image.permute({2, 0, 1});
    item.rays = ray_map.rays;
    item.distance = sample.distance;
    item.mask = sample.mask;
    item.negative = sky_known ? camera_valid & ~sample.mask : at::zeros_like(sample.mask);
    item.metric = at::full({}, sample.metric, at::kBool);

    // Conditions (paper: each enabled with probability 0.9 from stage 2; sparse depth sampled
    // from the GT at 0.05–0.1 % of the pixels).
    // (An A2P item's "GT" is its pseudo-label.)
    const bool with_rays = conditions && random.chance(config_.condition_probability);
    const bool with_depth = conditions && random.chance(config_.condition_probability);
    item.condition_rays =
        with_rays ? ray_map.rays.permute({2, 0, 1}) : at::zeros({3, height, width});
    if (with_depth) {
      const double ratio = random.uniform(config_.sparse_ratio[0], config_.sparse_ratio[1]);
      at::Generator generator = at::make_generator<at::CPUGeneratorImpl>(random.next_u64());
      item.condition_depth =
          geometry::sample_uniform_ratio(sample.distance, sample.mask, ratio, generator).depth;
    } else {
      item.condition_depth = at::zeros({height, width});
    }
    return item;
  };
  // Each item is a pure function of its index, so threads take whole items (their ops then
  // run single-threaded inside) and the batch does not depend on the thread count. A2P's
  // teacher runs a network per item: those batches stay on the calling thread.
  std::vector<Item> items(static_cast<size_t>(batch_size));
  if (config_.a2p) {
    for (int64_t k = 0; k < batch_size; ++k) items[k] = make_item(k);
  } else {
    util::parallel_for(0, batch_size, 1, [&](int64_t begin, int64_t end) {
      for (int64_t k = begin; k < end; ++k) items[k] = make_item(k);
    });
  }
  const auto stacked = [&](at::Tensor Item::*field) {
    std::vector<at::Tensor> parts;
    parts.reserve(items.size());
    for (const Item& item : items) parts.push_back(item.*field);
    return at::stack(parts);
  };
  TrainingBatch batch;
  batch.image = stacked(&Item::image).contiguous();
  batch.condition_rays = stacked(&Item::condition_rays).contiguous();
  batch.condition_sparse_depth = stacked(&Item::condition_depth).contiguous();
  batch.targets.rays = stacked(&Item::rays);
  batch.targets.distance = stacked(&Item::distance);
  batch.targets.mask = stacked(&Item::mask);
  batch.targets.mask_negative = stacked(&Item::negative);
  batch.targets.metric = stacked(&Item::metric);
  data::synth::Random tokens(
      derived_seed(config_.seed, stream ^ kTokenStream, static_cast<uint64_t>(step)), 0);
  batch.num_tokens = tokens.integer(static_cast<int>(config_.num_tokens[0]),
                                    static_cast<int>(config_.num_tokens[1]));
  return batch;
}

}  // namespace omnipoint::train
