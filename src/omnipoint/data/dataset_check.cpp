#include "omnipoint/data/dataset_check.h"

#include <ATen/ATen.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <new>
#include <optional>
#include <stdexcept>
#include <utility>

#include "omnipoint/data/sample.h"
#include "omnipoint/data/transform.h"
#include "omnipoint/geometry/colormap.h"
#include "omnipoint/io/image.h"

namespace omnipoint::data {
namespace fs = std::filesystem;

void DatasetCheckOptions::Check() const {
  if (format.empty()) throw std::invalid_argument("data check: the format is not given");
  if (location.path.empty()) throw std::invalid_argument("data check: the root is not given");
  if (limit < 0) throw std::invalid_argument("data check: limit must be >= 0 (0: every item)");
  if (sheet_items < 1) throw std::invalid_argument("data check: sheet_items must be >= 1");
  if (sheet_height < 8 || sheet_height > 4096)
    throw std::invalid_argument("data check: sheet_height must be in [8, 4096]");
}

DatasetCheck::DatasetCheck(DatasetCheckOptions options) : options_(std::move(options)) {
  options_.Check();
}

namespace {

// `count` indices spread evenly over [0, size): the first, the last and between.
std::vector<int64_t> spread(int64_t size, int64_t count) {
  if (count <= 0 || count >= size) {
    std::vector<int64_t> all(static_cast<size_t>(size));
    for (int64_t i = 0; i < size; ++i) all[static_cast<size_t>(i)] = i;
    return all;
  }
  std::vector<int64_t> picked;
  for (int64_t k = 0; k < count; ++k)
    picked.push_back(count == 1 ? 0 : k * (size - 1) / (count - 1));
  return picked;
}

// One row of the contact sheet: the image beside its distance (Turbo by inverse distance,
// unlabelled black), `height` pixels high.
at::Tensor sheet_row(const Sample& sample, int64_t height) {
  const double aspect =
      static_cast<double>(sample.camera.width()) / static_cast<double>(sample.camera.height());
  const int64_t width = std::max<int64_t>(1, std::llround(aspect * static_cast<double>(height)));
  const Sample small = resize_sample(sample, width, height);
  const at::Tensor distance = geometry::colorize_depth(small.distance, small.mask);
  return at::cat({small.image, distance.to(at::kFloat)}, 1);
}

// The rows stacked, each padded on the right with black to the widest.
at::Tensor stack_rows(const std::vector<at::Tensor>& rows) {
  int64_t width = 0;
  for (const at::Tensor& row : rows) width = std::max(width, row.size(1));
  std::vector<at::Tensor> padded;
  padded.reserve(rows.size());
  for (const at::Tensor& row : rows)
    padded.push_back(at::constant_pad_nd(row, {0, 0, 0, width - row.size(1)}, 0));
  return at::cat(padded, 0);
}

}  // namespace

DatasetCheckReport DatasetCheck::Run() const {
  const std::unique_ptr<Dataset> dataset = open_dataset(options_.format, options_.location);
  DatasetCheckReport report;
  report.items = dataset->size();
  std::error_code error;
  for (int64_t i = 0; i < report.items; ++i)
    for (const std::string& source : dataset->item_sources({i, 0}))
      if (!fs::exists(source, error)) report.missing.push_back(source);

  const std::vector<int64_t> chosen = spread(report.items, options_.limit);
  const std::vector<int64_t> on_sheet =
      spread(static_cast<int64_t>(chosen.size()), options_.sheet_items);
  std::vector<at::Tensor> rows;
  double density_sum = 0;
  report.density_min = std::numeric_limits<double>::infinity();
  report.distance_min = std::numeric_limits<double>::infinity();
  int64_t good = 0;
  for (size_t k = 0; k < chosen.size(); ++k) {
    const ItemIndex index{chosen[k], 0};
    ++report.read;
    std::optional<Sample> read;
    try {
      read.emplace(dataset->item(index));
    } catch (const std::bad_alloc&) {
      throw;
    } catch (const std::exception& failure) {
      report.failed.emplace_back(failure.what());
      continue;
    }
    const Sample& sample = *read;
    ++good;
    ++report.camera_models[sample.camera.model_name()];
    if (sample.metric) ++report.metric_items;
    const double density = sample.mask.to(at::kDouble).mean().item<double>();
    density_sum += density;
    report.density_min = std::min(report.density_min, density);
    report.density_max = std::max(report.density_max, density);
    if (sample.mask.any().item<bool>()) {
      const at::Tensor labelled = sample.distance.masked_select(sample.mask);
      report.distance_min = std::min(report.distance_min, labelled.min().item<double>());
      report.distance_max = std::max(report.distance_max, labelled.max().item<double>());
    }
    if (!options_.sheet_path.empty() &&
        std::find(on_sheet.begin(), on_sheet.end(), static_cast<int64_t>(k)) != on_sheet.end())
      rows.push_back(sheet_row(sample, options_.sheet_height));
  }
  if (good == 0) report.density_min = 0;
  if (!std::isfinite(report.distance_min)) report.distance_min = 0;
  report.density_mean = good > 0 ? density_sum / static_cast<double>(good) : 0;
  if (!rows.empty()) io::write_image_png(options_.sheet_path, stack_rows(rows));
  return report;
}

}  // namespace omnipoint::data
