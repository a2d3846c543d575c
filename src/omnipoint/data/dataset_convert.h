#pragma once
// `omnipoint data convert`: the items of a dataset in any format of the format table
// (dataset_formats.h), read through its reader and written as this project's sample folders
// (sample.h, docs/DATASET.md), one per item, plus OUT/manifest.jsonl naming each folder's item
// and source files. The converted folder opens with the "folders" format.
//   - Folder names come from the item names (relative to the root, separators and unsafe
//     characters replaced): a rerun names the same item the same folder.
//   - Each folder is written staged (io/staged_folder.h): it appears complete or not at all.
//   - An item that does not read or fails validation is skipped with a warning (the observer's)
//     and counted; anything else (the output not writable, memory) stops the run.
//   - An output folder holding anything is refused unless `resume` (items whose folder exists
//     are kept as they are) or `overwrite` (they are written anew).
#include <cstdint>
#include <string>
#include <vector>

#include "omnipoint/data/dataset.h"

namespace omnipoint::data {

struct DatasetConvertOptions {
  std::string format;        // a name of the format table (`omnipoint data formats`)
  DatasetLocation location;  // the root, split and format options
  std::string output_path;   // the folder of sample folders (created)
  // The dataset's own camera (image_02) and sequence (scene, area) names: the format's options
  // "camera" and "sequence"; "" leaves the format's default. A format without the option
  // refuses it (by name).
  std::string camera;
  std::string sequence;
  int64_t every = 1;       // every K-th item of the dataset's order, from the first
  int64_t limit = 0;       // at most this many of those (0: all)
  bool resume = false;     // keep the items whose folders exist (an interrupted run)
  bool overwrite = false;  // write every item anew into an output folder holding others
  // Throws std::invalid_argument naming the first bad field.
  void Check() const;
};

// One item of a run, as the observer and the manifest see it.
struct ConvertedItem {
  int64_t index = 0;                 // in the dataset
  std::string name;                  // Dataset::item_name
  std::string folder;                // the sample folder's name under the output folder
  std::vector<std::string> sources;  // Dataset::item_sources
};

struct DatasetConvertReport {
  int64_t items = 0;                 // chosen by every/limit
  int64_t converted = 0;             // written in this run
  int64_t kept = 0;                  // existing folders kept (resume)
  std::vector<std::string> skipped;  // "ITEM: why", one per item that did not read
  std::string manifest_path;         // OUT/manifest.jsonl
};

class DatasetConvertObserver {
 public:
  virtual ~DatasetConvertObserver() = default;
  // The items chosen, before the first is read.
  virtual void on_start(int64_t /*items*/) {}
  // Item `ordinal` (0-based among those chosen) is about to be read.
  virtual void on_item(int64_t /*ordinal*/, const ConvertedItem& /*item*/) {}
  // An item skipped: its name and why (the warning line's text).
  virtual void on_skipped(const ConvertedItem& /*item*/, const std::string& /*why*/) {}
  // Item `ordinal` is done: written, kept or skipped.
  virtual void on_item_done(int64_t /*ordinal*/) {}
};

class DatasetConvert {
 public:
  // `observer` (may be null) must outlive Run().
  explicit DatasetConvert(DatasetConvertOptions options,
                          DatasetConvertObserver* observer = nullptr);
  // Opens the dataset (its errors propagate), writes the folders and the manifest.
  DatasetConvertReport Run() const;

 private:
  DatasetConvertOptions options_;
  DatasetConvertObserver* observer_;
};

// The sample folder name of an item named `item` in a dataset at `root`: the path relative to
// the root (where it lies under it) without its extension, '/' as "-", characters other than
// letters, digits, '_', '-', '.' as '_', no leading '.', at most 200 characters (the end kept).
std::string sample_folder_name(const std::string& item, const std::string& root);

}  // namespace omnipoint::data
