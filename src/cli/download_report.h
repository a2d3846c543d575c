#pragma once
// What a model download shows (io::hub::DownloadObserver): a line when it starts, on a terminal
// a progress bar redrawn in place (size, percentage, rate), nothing more in logs and pipes; its
// notes (a resumed transfer, the cached copy used offline) as note lines. All on stderr.
#include <chrono>
#include <cstdint>
#include <string>

#include "omnipoint/io/hub.h"

namespace omnipoint::cli {

class DownloadReport : public io::hub::DownloadObserver {
 public:
  DownloadReport();
  void started(const std::string& name, std::int64_t bytes, std::int64_t resumed_at) override;
  void progress(std::int64_t present, std::int64_t bytes) override;
  void finished() override;
  void note(const std::string& text) override;

 private:
  void clear();

  bool terminal_;
  bool drawn_ = false;
  std::int64_t resumed_at_ = 0;
  std::chrono::steady_clock::time_point started_, drawn_at_;
};

// The local file of a --model value (or $OMNIPOINT_MODEL's): a hub reference (io/hub.h) is
// fetched into the cache with a DownloadReport; anything else is a file path, returned as it
// is.
std::string resolve_model(const std::string& model);

}  // namespace omnipoint::cli
