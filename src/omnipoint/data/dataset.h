#pragma once
// Map-style datasets: a number of items and the item at an index, each a data::Sample — what
// a dataset reader provides, apart from how items are drawn into batches and stacked (that is
// the training's: train/batch_source.h). A reader of a format on disk registers itself under a
// name (open_dataset); the built-in ones (the table in dataset_formats.cpp):
//   "folders"  a directory of sample folders in the format of sample.h (one item per folder,
//              in name order; a staging folder (io/staged_folder.h) is a sample still
//              being written, left out)
//   "moge"     a MoGe evaluation benchmark root (moge_format.h; its .index.txt order)
//   "kitti-raw", "kitti360", "rig-log"   driving logs with sparse LiDAR labels (formats/)
//   "hypersim", "vkitti2"                rendered training sets (formats/)
// The synthetic scene engine is a dataset too (synth/synth_dataset.h), made in memory.
#include <cstdint>
#include <functional>
#include <map>
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
  // The files the item is read from (`omnipoint data convert`'s manifest, `data check`'s
  // missing files): by default its name alone.
  virtual std::vector<std::string> item_sources(const ItemIndex& index) const;
  // An item drawn uniformly with `random`: by default the index random.integer(0, size() - 1).
  virtual ItemIndex draw(synth::Random& random) const;
};

// A dataset of named items, each read by a function of its name (a folder, a file, a line of
// a split list): what most readers of a format on disk are. A reader's exception becomes a
// SampleError (its text names the item); memory exhaustion stays what it is. `sources`, when
// given, names the files an item is read from (item_sources).
class ListDataset : public Dataset {
 public:
  using Sources = std::function<std::vector<std::string>(const std::string&)>;
  ListDataset(std::vector<std::string> items, std::function<Sample(const std::string&)> read,
              Sources sources = {});
  int64_t size() const override;
  Sample item(const ItemIndex& index) const override;
  std::string item_name(const ItemIndex& index) const override;
  std::vector<std::string> item_sources(const ItemIndex& index) const override;

 private:
  std::vector<std::string> items_;
  std::function<Sample(const std::string&)> read_;
  Sources sources_;
};

// Where a dataset on disk is, and what its files may not say themselves.
struct DatasetLocation {
  std::string path;     // the dataset's root folder
  bool metric = false;  // formats without a per-sample flag ("moge"): the depth is in metres
  // The format's split: one of its own split names, or a split-list file (one item a line, as
  // the format's documentation says); "" for every item the root holds.
  std::string split = {};
  // The format's options by name (e.g. a camera, a ground-truth rule), as the user wrote them;
  // open_dataset refuses a name the format does not declare.
  std::map<std::string, std::string> options = {};
};

using DatasetReader = std::function<std::unique_ptr<Dataset>(const DatasetLocation&)>;

// A format, as `omnipoint data formats` lists it.
struct DatasetFormat {
  std::string name;     // "kitti360", "folders", ...
  std::string summary;  // one line: what the reader expects under the root
  // The options it takes: name -> one line of help (values and the default).
  std::map<std::string, std::string> options = {};
  std::vector<std::string> splits;  // its named splits, if it has any
  DatasetReader open;
};

// Adds a format; std::invalid_argument when the name is empty or taken or there is no reader.
void register_dataset_format(DatasetFormat format);
void register_dataset_format(const std::string& name, DatasetReader reader);
// The registered formats (their names sorted), and their names alone.
std::vector<DatasetFormat> dataset_format_list();
std::vector<std::string> dataset_formats();
// The dataset at `location` in format `format`. An unknown format or an option the format does
// not declare -> std::invalid_argument naming the known ones; a root that is missing or holds
// no item -> std::runtime_error naming it (the reader's).
std::unique_ptr<Dataset> open_dataset(const std::string& format, const DatasetLocation& location);

// The value of option `name`, or `fallback` when not given.
std::string option_or(const DatasetLocation& location, const std::string& name,
                      const std::string& fallback);

}  // namespace omnipoint::data
