#pragma once
// The synthetic scene engine as a dataset (data/dataset.h): every pair of a scene kind and a
// camera is an item, and each draw renders a new scene instance of it (the draw's seed), so
// the items never repeat.
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/synth/scene.h"

namespace omnipoint::data::synth {

class SynthDataset : public Dataset {
 public:
  // At least one scene kind and one camera (std::invalid_argument otherwise). The scene kinds
  // and cameras may repeat: a repeated one is drawn more often.
  SynthDataset(std::vector<SceneKind> scenes, std::vector<camera::Camera> cameras);

  // Item index = scene * cameras + camera.
  int64_t size() const override;
  // The scene of the item's kind with seed `index.seed`, rendered through its camera.
  Sample item(const ItemIndex& index) const override;
  // "synth:KIND:SEED".
  std::string item_name(const ItemIndex& index) const override;
  // The scene kind, the camera (each uniformly) and then the seed, in that order.
  ItemIndex draw(Random& random) const override;

 private:
  std::vector<SceneKind> scenes_;
  std::vector<camera::Camera> cameras_;
};

}  // namespace omnipoint::data::synth
