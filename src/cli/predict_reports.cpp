#include "cli/predict_reports.h"

namespace omnipoint::cli {

void PredictReports::start(const predict::ImageList& images) {
  progress_.emplace(static_cast<int64_t>(images.images.size()));
}

void PredictReports::note(const std::string& text) {
  progress_->line("omnipoint: note: " + text);
}

void PredictReports::image_started(size_t index, const predict::ImageEntry& image) {
  progress_->start(static_cast<int64_t>(index), image.relative.string());
}

void PredictReports::warning(const predict::ImageEntry& image, const std::string& text) {
  progress_->line("omnipoint: warning: " + progress_->prefix() + image.path.string() + ": " + text);
}

void PredictReports::image_written(const predict::ImageEntry& image,
                                   const predict::PredictedImage& predicted) {
  progress_->line(progress_->prefix() + predict::describe(image, predicted));
  for (const std::string& note : predicted.prediction.notes) progress_->line("  note: " + note);
  if (!predicted.prediction.fit_error.empty())
    progress_->line("  note: no camera fitted: " + predicted.prediction.fit_error);
}

void PredictReports::image_failed(const predict::ImageEntry& image, const std::string& error) {
  progress_->line("omnipoint: error: " + progress_->prefix() + "skipped " + image.path.string() +
                  ": " + error);
}

void PredictReports::image_done(size_t /*index*/) {
  progress_->done();
}

void PredictReports::finished(const predict::PredictJobSummary& summary) {
  if (!summary.fused_cloud.empty())
    progress_->line(summary.fused_cloud + ": " + std::to_string(summary.fused_points) +
                    " points of " + std::to_string(summary.fused_images) +
                    " images in the reconstruction's world frame");
  progress_->line(std::to_string(summary.images) + " image(s): " + std::to_string(summary.written) +
                  " written, " + std::to_string(summary.failed) + " failed, " +
                  std::to_string(summary.warnings) + " warning(s)");
}

void RigPredictReports::start(const io::Rig& rig, const std::vector<std::string>& frames) {
  progress_.emplace(static_cast<int64_t>(frames.size()));
  progress_->line("rig of " + std::to_string(rig.cameras.size()) + " camera(s)" +
                  (rig.lidar ? " and a LiDAR" : "") + ", " + std::to_string(frames.size()) +
                  " frame(s)");
}

void RigPredictReports::frame_started(size_t index, const std::string& frame) {
  progress_->start(static_cast<int64_t>(index), frame);
}

void RigPredictReports::warning(const std::string& frame, const std::string& text) {
  progress_->line("omnipoint: warning: " + progress_->prefix() + "frame " + frame + ": " + text);
}

void RigPredictReports::frame_written(const predict::RigFrameResult& frame) {
  progress_->line(progress_->prefix() + predict::describe(frame));
}

void RigPredictReports::frame_resumed(size_t /*index*/, const std::string& frame,
                                      double rig_scale) {
  progress_->line(progress_->prefix() + "frame " + frame +
                  ": finished by an earlier run, not redone (rig scale " +
                  std::to_string(rig_scale) + ")");
}

void RigPredictReports::frame_failed(const std::string& frame, const std::string& error) {
  progress_->line("omnipoint: error: " + progress_->prefix() + "skipped frame " + frame + ": " +
                  error);
}

void RigPredictReports::frame_done(size_t /*index*/) {
  progress_->done();
}

void RigPredictReports::finished(const predict::RigPredictJobSummary& summary) {
  progress_->line(std::to_string(summary.frames) + " frame(s): " + std::to_string(summary.written) +
                  " written, " +
                  (summary.resumed > 0 ? std::to_string(summary.resumed) + " resumed, " : "") +
                  std::to_string(summary.failed) + " failed, " + std::to_string(summary.warnings) +
                  " warning(s)");
}

void SequencePredictReports::start(const predict::ImageList& frames) {
  progress_.emplace(static_cast<int64_t>(frames.images.size()));
}

void SequencePredictReports::note(const std::string& text) {
  progress_->line("omnipoint: note: " + text);
}

void SequencePredictReports::frame_started(size_t index, const predict::ImageEntry& frame) {
  progress_->start(static_cast<int64_t>(index), frame.relative.string());
}

void SequencePredictReports::frame_resumed(size_t /*index*/, const predict::ImageEntry& frame,
                                           double metric_scale) {
  progress_->line(progress_->prefix() + frame.path.string() +
                  ": finished by an earlier run, not redone (metric scale " +
                  std::to_string(metric_scale) + ")");
  progress_->done();
}

void SequencePredictReports::warning(const predict::ImageEntry& frame, const std::string& text) {
  progress_->line("omnipoint: warning: " + progress_->prefix() + frame.path.string() + ": " + text);
}

void SequencePredictReports::frame_written(size_t /*index*/, const predict::ImageEntry& frame,
                                           const predict::PredictedImage& predicted,
                                           double network_scale) {
  progress_->line(progress_->prefix() + predict::describe(frame, predicted) +
                  " (the network's scale " + std::to_string(network_scale) + ")");
  progress_->done();
}

void SequencePredictReports::frame_failed(size_t /*index*/, const predict::ImageEntry& frame,
                                          const std::string& error) {
  progress_->line("omnipoint: error: " + progress_->prefix() + "skipped " + frame.path.string() +
                  ": " + error);
  progress_->done();
}

void SequencePredictReports::finished(const predict::SequencePredictJobSummary& summary) {
  progress_->line(std::to_string(summary.frames) + " frame(s): " + std::to_string(summary.written) +
                  " written, " + std::to_string(summary.resumed) + " resumed (finished earlier), " +
                  std::to_string(summary.failed) + " failed, " + std::to_string(summary.warnings) +
                  " warning(s)");
}

}  // namespace omnipoint::cli
