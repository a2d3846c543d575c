#pragma once
// What `omnipoint predict` prints while its job runs (predict::PredictJobObserver, and
// predict::RigPredictJobObserver for --rig, per frame; predict::SequencePredictJobObserver for
// --sequence): each report
// as a line on stderr around the progress bar (cli/progress.h); an image's lines carry the
// bar's "[i/N] " on plain output.
#include <optional>
#include <string>
#include <vector>

#include "cli/progress.h"
#include "omnipoint/predict/predict_job.h"
#include "omnipoint/predict/rig_predict_job.h"
#include "omnipoint/predict/sequence_predict_job.h"

namespace omnipoint::cli {

class PredictReports : public predict::PredictJobObserver {
 public:
  void start(const predict::ImageList& images) override;
  void note(const std::string& text) override;
  void image_started(size_t index, const predict::ImageEntry& image) override;
  void warning(const predict::ImageEntry& image, const std::string& text) override;
  void image_written(const predict::ImageEntry& image,
                     const predict::PredictedImage& predicted) override;
  void image_failed(const predict::ImageEntry& image, const std::string& error) override;
  void image_done(size_t index) override;
  void finished(const predict::PredictJobSummary& summary) override;

 private:
  std::optional<Progress> progress_;
};

class RigPredictReports : public predict::RigPredictJobObserver {
 public:
  void start(const io::Rig& rig, const std::vector<std::string>& frames) override;
  void frame_started(size_t index, const std::string& frame) override;
  void warning(const std::string& frame, const std::string& text) override;
  void frame_written(const predict::RigFrameResult& frame) override;
  void frame_resumed(size_t index, const std::string& frame, double rig_scale) override;
  void frame_failed(const std::string& frame, const std::string& error) override;
  void frame_done(size_t index) override;
  void finished(const predict::RigPredictJobSummary& summary) override;

 private:
  std::optional<Progress> progress_;
};

class SequencePredictReports : public predict::SequencePredictJobObserver {
 public:
  void start(const predict::ImageList& frames) override;
  void note(const std::string& text) override;
  void frame_started(size_t index, const predict::ImageEntry& frame) override;
  void frame_resumed(size_t index, const predict::ImageEntry& frame, double metric_scale) override;
  void warning(const predict::ImageEntry& frame, const std::string& text) override;
  void frame_written(size_t index, const predict::ImageEntry& frame,
                     const predict::PredictedImage& predicted, double network_scale) override;
  void frame_failed(size_t index, const predict::ImageEntry& frame,
                    const std::string& error) override;
  void finished(const predict::SequencePredictJobSummary& summary) override;

 private:
  std::optional<Progress> progress_;
};

}  // namespace omnipoint::cli
