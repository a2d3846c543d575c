#include "omnipoint/data/synth/synth_dataset.h"

#include <stdexcept>
#include <string>
#include <utility>

#include "omnipoint/data/synth/random.h"
#include "omnipoint/data/synth/synthesize.h"

namespace omnipoint::data::synth {

SynthDataset::SynthDataset(std::vector<SceneKind> scenes, std::vector<camera::Camera> cameras)
    : scenes_(std::move(scenes)), cameras_(std::move(cameras)) {
  if (scenes_.empty() || cameras_.empty())
    throw std::invalid_argument("synthetic dataset: needs at least one scene kind and one camera");
}

int64_t SynthDataset::size() const {
  return static_cast<int64_t>(scenes_.size() * cameras_.size());
}

Sample SynthDataset::item(const ItemIndex& index) const {
  const auto count = static_cast<int64_t>(cameras_.size());
  return synthesize(scenes_.at(static_cast<size_t>(index.index / count)), index.seed,
                    cameras_.at(static_cast<size_t>(index.index % count)))
      .sample;
}

std::string SynthDataset::item_name(const ItemIndex& index) const {
  const auto count = static_cast<int64_t>(cameras_.size());
  return "synth:" + scene_kind_name(scenes_.at(static_cast<size_t>(index.index / count))) + ":" +
         std::to_string(index.seed);
}

ItemIndex SynthDataset::draw(Random& random) const {
  const int scene = random.integer(0, static_cast<int>(scenes_.size()) - 1);
  const int camera = random.integer(0, static_cast<int>(cameras_.size()) - 1);
  return {static_cast<int64_t>(scene) * static_cast<int64_t>(cameras_.size()) + camera,
          random.next_u64()};
}

}  // namespace omnipoint::data::synth
