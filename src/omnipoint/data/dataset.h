#pragma once
// Map-style datasets: a number of items and the item at an index, each a data::Sample — what
// a dataset reader provides, apart from how items are drawn into batches and stacked (that is
// the training's: train/batch_source.h). A reader of a format on disk registers itself under a
// name (open_dataset); the built-in ones:
//   "folders"  a directory of sample folders in the format of sample.h (one item per folder,
//              in name order; a staging folder (io/staged_folder.h) is a sample still
//              being written, left out)
//   "moge"     a MoGe evaluation benchmark root (moge_format.h; its .index.txt order)
// The synthetic scene engine is a dataset too (synth/synth_dataset.h), made in memory.
#include <cstdint>
#include <functional>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "omnipoint/data/sample.h"

namespace omnipoint::data::synth {
class Random;
}

namespace omnipoint::data {

// An item that cannot be read or fails validation (missing or corrupt files, NaN depth, ...):
// the one error of Dataset::item a caller may skip the item for. Its text names the item.
class SampleError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Which item: an index below size(), and the draw's own seed, for datasets whose items vary
// from draw to draw (the synthetic engine renders a new scene instance for each seed); a
// dataset of fixed items ignores it.
struct ItemIndex {
  int64_t index = 0;
  uint64_t seed = 0;
};
bool operator<(const ItemIndex& a, const ItemIndex& b);

class Dataset {
 public:
  virtual ~Dataset();
  // The number of items (at least one).
  virtual int64_t size() const = 0;
  // The item, read (or made) anew on each call. SampleError for a bad item; safe to call from
  // several threads at once.
  virtual Sample item(const ItemIndex& index) const = 0;
  // How messages name the item (its folder, for a dataset on disk).
  virtual std::string item_name(const ItemIndex& index) const = 0;
  // An item drawn uniformly with `random`: by default the index random.integer(0, size() - 1).
  virtual ItemIndex draw(synth::Random& random) const;
};

// Where a dataset on disk is, and what its files may not say themselves.
struct DatasetLocation {
  std::string path;     // the dataset's root folder
  bool metric = false;  // formats without a per-sample flag ("moge"): the depth is in metres
};

using DatasetReader = std::function<std::unique_ptr<Dataset>(const DatasetLocation&)>;

// Adds a format under `name`; std::invalid_argument when the name is empty or taken.
void register_dataset_format(const std::string& name, DatasetReader reader);
// The names of the registered formats, sorted.
std::vector<std::string> dataset_formats();
// The dataset at `location` in format `format`. An unknown format -> std::invalid_argument
// naming the known ones; a root that is missing or holds no item -> std::runtime_error naming
// it (the reader's).
std::unique_ptr<Dataset> open_dataset(const std::string& format, const DatasetLocation& location);

}  // namespace omnipoint::data
