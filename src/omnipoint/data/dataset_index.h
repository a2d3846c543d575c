#pragma once
// Finding the samples of an evaluation dataset on disk, whatever its layout:
//   - a sample folder of our format (sample.h: meta.json + distance.npy or depth.npy),
//   - a MoGe benchmark instance (moge_format.h: meta.json + depth.png),
//   - a MoGe benchmark root with .index.txt (its instances, in index order),
//   - any folder holding such folders, searched recursively (sorted by name) up to
//     kMaxDatasetDepth levels, e.g. a benchmark root with one folder per split.
// Each sample's id is its folder's path relative to the root ("/"-separated), or the folder's
// own name when the root is itself a sample.
#include <string>
#include <vector>

#include "omnipoint/data/sample.h"

namespace omnipoint::data {

constexpr int kMaxDatasetDepth = 4;

enum class SampleFormat { kFolder, kMoge };

struct DatasetItem {
  std::string path;  // the sample folder
  std::string id;    // relative to the dataset root
  SampleFormat format;
};

// A missing root or one without any sample -> std::runtime_error naming the root and the
// layouts looked for.
std::vector<DatasetItem> list_dataset(const std::string& root);

// Reads one item (read_sample or read_moge_instance; `moge_metric` says whether a MoGe
// benchmark's depth is metric). Errors as those readers.
Sample read_dataset_item(const DatasetItem& item, bool moge_metric);

}  // namespace omnipoint::data
