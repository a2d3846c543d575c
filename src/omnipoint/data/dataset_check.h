#pragma once
// `omnipoint data check`: what a dataset on disk holds, read through its format's reader (the
// table of dataset_formats.h): the items listed, the source files missing, the items that do
// not read (each with its one-line error), the camera models, the share of labelled pixels and
// the distance range; optionally a contact sheet PNG (image | distance) of a few items.
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "omnipoint/data/dataset.h"

namespace omnipoint::data {

struct DatasetCheckOptions {
  std::string format;        // a name of the format table (`omnipoint data formats`)
  DatasetLocation location;  // the root, split and format options
  // Items read, spread evenly over the dataset (0: every item). Missing files are looked for
  // in every item regardless.
  int64_t limit = 0;
  std::string sheet_path;      // the contact sheet PNG ("" writes none)
  int64_t sheet_items = 4;     // items on the contact sheet, one row each
  int64_t sheet_height = 160;  // each row's height in pixels
  // Throws std::invalid_argument naming the first bad field.
  void Check() const;
};

struct DatasetCheckReport {
  int64_t items = 0;                             // listed by the reader
  int64_t read = 0;                              // items read (limit), of which `failed` did not
  std::vector<std::string> missing;              // source files that do not exist
  std::vector<std::string> failed;               // "ITEM: why", one per item that did not read
  std::map<std::string, int64_t> camera_models;  // model name -> items read with it
  // Labelled share of each read item's pixels, and the labelled distances (metres when the
  // items are metric), over the items read; 0 when none read.
  double density_min = 0, density_mean = 0, density_max = 0;
  double distance_min = 0, distance_max = 0;
  int64_t metric_items = 0;  // items read whose distances are metric
  bool ok() const { return missing.empty() && failed.empty(); }
};

class DatasetCheck {
 public:
  explicit DatasetCheck(DatasetCheckOptions options);
  // Opens the dataset (its errors propagate), reads the items, writes the sheet.
  DatasetCheckReport Run() const;

 private:
  DatasetCheckOptions options_;
};

}  // namespace omnipoint::data
