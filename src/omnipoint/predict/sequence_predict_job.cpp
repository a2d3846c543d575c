#include "omnipoint/predict/sequence_predict_job.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <future>
#include <map>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "omnipoint/camera/fit.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/predict/inputs.h"
#include "omnipoint/predict/median.h"
#include "omnipoint/predict/sequence_record.h"

namespace omnipoint::predict {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// What an earlier run recorded of a finished frame (its camera.json's sequence record).
struct FinishedFrame {
  fs::path camera_json;
  double network_scale = 0;
  double metric_scale = 0;
  std::string camera_origin;
};

// The finished frame's record in `folder`, or nullopt when the folder is not a finished frame
// of a sequence (read_sequence_record).
std::optional<FinishedFrame> finished_frame(const fs::path& folder, ScaleMode mode) {
  const fs::path file = folder / "camera.json";
  const std::optional<json> record = read_sequence_record(file, mode);
  if (!record) return std::nullopt;
  FinishedFrame frame;
  frame.camera_json = file;
  frame.network_scale = record->at("network_metric_scale").get<double>();
  frame.metric_scale = record->at("metric_scale").get<double>();
  frame.camera_origin = record->value("camera", "");
  return frame;
}

// One Run().
class SequenceRun {
 public:
  SequenceRun(const SequencePredictJobOptions& options, SequencePredictJobObserver& observer)
      : options_(options), observer_(observer) {}
  SequencePredictJobSummary run();

 private:
  DecodedImage decode(size_t index) const {
    return read_input_image(list_.images[index].path.string(), options_.max_size,
                            options_.use_exif);
  }
  PredictOptions predict_options() const {
    PredictOptions item;
    item.num_tokens = options_.num_tokens;
    item.precision = options_.precision;
    item.edge_rtol = options_.edge_rtol;
    if (camera_) item.camera = *camera_;
    return item;
  }
  void find_finished_frames();
  size_t calibration_count() const {
    return std::min(list_.images.size(), static_cast<size_t>(options_.calibration_frames));
  }
  void calibrate_camera();
  void measure_fixed_scale();
  void predict_frame(size_t index, const DecodedImage& decoded, SequenceScale& scale);

  const SequencePredictJobOptions& options_;
  SequencePredictJobObserver& observer_;
  ImageList list_;
  std::map<size_t, FinishedFrame> finished_;
  std::optional<Model> model_;
  std::optional<camera::Camera> camera_;
  std::string camera_origin_;
  double fixed_scale_ = 0;
  SequencePredictJobSummary summary_;
};

void SequenceRun::find_finished_frames() {
  for (size_t i = 0; i < list_.images.size(); ++i)
    if (auto frame =
            finished_frame(fs::path(options_.output_dir) / list_.images[i].output, options_.scale))
      finished_.emplace(i, std::move(*frame));
}

// The camera (without a given one) from the first frames: their automatic fits vote.
void SequenceRun::calibrate_camera() {
  std::vector<at::Tensor> rays, valid;
  std::vector<camera::Camera> fits;  // each frame's automatic fit, in frame order
  std::optional<camera::ImageSize> size;
  std::string errors;
  for (size_t i = 0; i < calibration_count(); ++i) {
    try {
      const DecodedImage decoded = decode(i);
      PredictOptions item = predict_options();
      item.fit_model = "auto";
      const Prediction p = model_->predict(decoded.image, item);
      if (!p.fitted_camera) throw std::runtime_error("no camera fitted: " + p.fit_error);
      if (size && (size->width != decoded.size.width || size->height != decoded.size.height))
        throw std::invalid_argument("--sequence: the calibration frames differ in size (" +
                                    list_.images[i].path.string() +
                                    "): a sequence is one camera's frames");
      size = decoded.size;
      fits.push_back(*p.fitted_camera);
      rays.push_back(p.rays);
      valid.push_back(p.mask);
    } catch (const std::invalid_argument&) {
      throw;
    } catch (const std::exception& e) {
      errors += "; " + list_.images[i].path.string() + ": " + e.what();
    }
  }
  if (fits.empty())
    throw std::runtime_error("--sequence: none of the " + std::to_string(calibration_count()) +
                             " calibration frame(s) could be predicted" + errors);
  std::map<std::string, int> count_of;
  for (const camera::Camera& fit : fits) ++count_of[fit.model_name()];
  const camera::Camera* first_chosen = &fits.front();  // the first fit of the most chosen model
  for (const camera::Camera& fit : fits)
    if (count_of[fit.model_name()] > count_of[first_chosen->model_name()]) first_chosen = &fit;
  const std::string chosen = first_chosen->model_name();
  // Started from that frame's own fit (camera/fit.h says why).
  const camera::CameraFit fit = camera::fit_camera_model_to_images(
      chosen, size->width, size->height, at::stack(rays), at::stack(valid), first_chosen);
  camera_ = fit.camera;
  camera_origin_ = "calibrated from " + std::to_string(fits.size()) + " frames: " + chosen +
                   " (chosen by the automatic fit for " + std::to_string(count_of[chosen]) +
                   " of them), fitted to all their rays, residual " +
                   std::to_string(fit.residual.median_deg) + " deg median";
}

// --scale fixed: the median of the first frames' network scales, predicted with the camera.
void SequenceRun::measure_fixed_scale() {
  std::vector<double> network_scales;
  std::string errors;
  for (size_t i = 0; i < calibration_count(); ++i) {
    try {
      PredictOptions item = predict_options();
      item.fit_model = "";
      network_scales.push_back(model_->predict(decode(i).image, item).metric_scale);
    } catch (const std::exception& e) {
      errors += "; " + list_.images[i].path.string() + ": " + e.what();
    }
  }
  if (network_scales.empty())
    throw std::runtime_error("--sequence: none of the " + std::to_string(calibration_count()) +
                             " calibration frame(s) could be predicted" + errors);
  fixed_scale_ = median(network_scales);
}

void SequenceRun::predict_frame(size_t index, const DecodedImage& decoded, SequenceScale& scale) {
  const ImageEntry& entry = list_.images[index];
  PredictOptions item = predict_options();
  item.fit_model = "auto";  // reports the given camera as it is
  PredictedImage predicted;
  predicted.folder = (fs::path(options_.output_dir) / entry.output).string();
  predicted.original_size = decoded.original_size;
  predicted.size = decoded.size;
  predicted.decode_ms = decoded.decode_ms;
  predicted.prediction = model_->predict(decoded.image, item);
  const double network_scale = predicted.prediction.metric_scale;
  const double applied = scale.next(network_scale);
  apply_metric_scale(predicted.prediction, applied);
  OutputOptions outputs;
  outputs.files = options_.output_files;
  outputs.camera_json_extra = json{{"sequence",
                                    {{"frame_index", index},
                                     {"frames", list_.images.size()},
                                     {"camera", camera_origin_},
                                     {"scale_mode", scale_mode_name(options_.scale)},
                                     {"metric_scale", applied},
                                     {"network_metric_scale", network_scale}}}}
                                  .dump();
  predicted.writing_ms =
      write_prediction_outputs(predicted.folder, decoded.image, predicted.prediction, outputs);
  ++summary_.written;
  observer_.frame_written(index, entry, predicted, network_scale);
  for (const std::string& warning : predicted.prediction.warnings) {
    ++summary_.warnings;
    observer_.warning(entry, warning);
  }
}

SequencePredictJobSummary SequenceRun::run() {
  if (!io::image_io_available())
    throw std::runtime_error("this build has no image file I/O (OpenCV)");
  options_.Check();
  if (!fs::is_directory(options_.frames_dir))
    throw std::invalid_argument("--sequence " + options_.frames_dir + ": not a folder of frames");
  list_ = list_images({options_.frames_dir});
  summary_.frames = static_cast<int64_t>(list_.images.size());
  find_finished_frames();
  std::string camera_note;  // where a camera read back comes from
  if (!options_.camera.empty()) {
    const DecodedImage first = decode(0);  // the size of a camera file without one
    camera_ = io::read_camera(options_.camera, first.original_size);
    camera_origin_ = "given";
  } else if (!finished_.empty()) {
    const FinishedFrame& first = finished_.begin()->second;
    camera_ = io::read_camera(first.camera_json.string());
    camera_origin_ = first.camera_origin;
    camera_note = " (read back from " + first.camera_json.string() + ")";
  }
  model_ = Model::load(options_.model_path, options_.device);

  observer_.start(list_);
  if (list_.skipped_files > 0)
    observer_.note(std::to_string(list_.skipped_files) +
                   " file(s) in the frames folder are not images and were skipped");
  if (!camera_) calibrate_camera();
  if (options_.scale == ScaleMode::kFixed && finished_.empty()) measure_fixed_scale();
  if (!finished_.empty()) {
    fixed_scale_ = finished_.begin()->second.metric_scale;
    observer_.note(std::to_string(finished_.size()) + " of " + std::to_string(summary_.frames) +
                   " frame(s) finished by an earlier run in " + options_.output_dir +
                   ": not redone; the camera and the running scale continue from their "
                   "camera.json");
  }
  summary_.camera = camera_->to_spec();
  summary_.camera_origin = camera_origin_;
  if (options_.scale == ScaleMode::kFixed) summary_.fixed_scale = fixed_scale_;
  observer_.note("camera " + camera_origin_ + camera_note + ": " + summary_.camera);
  if (options_.scale == ScaleMode::kFixed)
    observer_.note("--scale fixed: metric scale " + std::to_string(fixed_scale_) +
                   " for every frame");

  SequenceScale scale(options_.scale, options_.scale == ScaleMode::kFixed ? fixed_scale_ : 1.0);
  // The next unfinished frame is decoded while the network runs on this one.
  const auto next_to_predict = [&](size_t from) {
    while (from < list_.images.size() && finished_.count(from) > 0) ++from;
    return from;
  };
  const auto decode_async = [&](size_t index) {
    return std::async(std::launch::async, [this, index] { return decode(index); });
  };
  std::future<DecodedImage> upcoming;
  size_t upcoming_index = next_to_predict(0);
  if (upcoming_index < list_.images.size()) upcoming = decode_async(upcoming_index);
  for (size_t i = 0; i < list_.images.size(); ++i) {
    const ImageEntry& entry = list_.images[i];
    observer_.frame_started(i, entry);
    if (const auto finished = finished_.find(i); finished != finished_.end()) {
      scale.next(finished->second.network_scale);
      ++summary_.resumed;
      observer_.frame_resumed(i, entry, finished->second.metric_scale);
      continue;
    }
    try {
      std::future<DecodedImage> current = std::exchange(upcoming, {});
      upcoming_index = next_to_predict(i + 1);
      if (upcoming_index < list_.images.size()) upcoming = decode_async(upcoming_index);
      predict_frame(i, current.get(), scale);
    } catch (const std::exception& e) {
      ++summary_.failed;
      observer_.frame_failed(i, entry, e.what());
    }
  }
  observer_.finished(summary_);
  return summary_;
}

}  // namespace

void SequencePredictJobOptions::Check() const {
  const auto fail = [](const std::string& text) { throw std::invalid_argument(text); };
  if (frames_dir.empty()) fail("--sequence: no frames folder given");
  if (calibration_frames < 1)
    fail("--calibration-frames " + std::to_string(calibration_frames) + ": expected >= 1");
  if (model_path.empty()) fail("--model: no model given");
  if (max_size < 0) fail("--max-size " + std::to_string(max_size) + ": expected >= 0");
  if (num_tokens < 0) fail("--num-tokens " + std::to_string(num_tokens) + ": expected >= 0");
  if (!(edge_rtol >= 0) || !std::isfinite(edge_rtol))
    fail("--edge-threshold " + std::to_string(edge_rtol) + ": expected a number >= 0");
  if (output_dir.empty()) fail("--out: no output folder given");
  const std::set<std::string> known = all_output_files();
  for (const std::string& file : output_files)
    if (known.count(file) == 0) fail("--outputs: unknown file \"" + file + "\"");
}

SequencePredictJob::SequencePredictJob(SequencePredictJobOptions options,
                                       SequencePredictJobObserver* observer)
    : options_(std::move(options)), observer_(observer) {}

SequencePredictJobSummary SequencePredictJob::Run() {
  SequencePredictJobObserver silent;
  return SequenceRun(options_, observer_ != nullptr ? *observer_ : silent).run();
}

}  // namespace omnipoint::predict
