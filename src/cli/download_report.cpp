#include "cli/download_report.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <sstream>

namespace omnipoint::cli {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

DownloadReport::DownloadReport() : terminal_(isatty(STDERR_FILENO) == 1) {}

void DownloadReport::started(const std::string& name, std::int64_t bytes, std::int64_t resumed_at) {
  resumed_at_ = resumed_at;
  started_ = std::chrono::steady_clock::now();
  drawn_at_ = {};
  std::string line = "omnipoint: downloading " + name;
  if (bytes >= 0) line += " (" + io::hub::human_bytes(bytes) + ")";
  if (resumed_at > 0) line += ", resuming at " + io::hub::human_bytes(resumed_at);
  std::cerr << line << "\n";
}

void DownloadReport::progress(std::int64_t present, std::int64_t bytes) {
  if (!terminal_) return;
  // A few redraws a second are enough for the eye.
  if (drawn_ && seconds_since(drawn_at_) < 0.2 && present != bytes) return;
  drawn_at_ = std::chrono::steady_clock::now();
  constexpr int kWidth = 24;
  std::ostringstream bar;
  bar << "\r\033[K  ";
  if (bytes > 0) {
    const int filled = static_cast<int>(kWidth * std::min(present, bytes) / bytes);
    bar << "[" << std::string(filled, '#') << std::string(kWidth - filled, '.') << "] "
        << 100 * present / bytes << "% of " << io::hub::human_bytes(bytes);
  } else {
    bar << io::hub::human_bytes(present);
  }
  const double elapsed = seconds_since(started_);
  if (elapsed > 0.5)
    bar << "  "
        << io::hub::human_bytes(static_cast<std::int64_t>((present - resumed_at_) / elapsed))
        << "/s";
  std::cerr << bar.str() << std::flush;
  drawn_ = true;
}

void DownloadReport::clear() {
  if (drawn_) std::cerr << "\r\033[K" << std::flush;
  drawn_ = false;
}

void DownloadReport::finished() {
  clear();
}

void DownloadReport::note(const std::string& text) {
  clear();
  std::cerr << "omnipoint: note: " << text << "\n";
}

std::string resolve_model(const std::string& model) {
  if (!io::hub::is_model_reference(model)) return model;
  DownloadReport report;
  return io::hub::resolve_model_path(model, io::hub::Settings::from_environment(), &report);
}

}  // namespace omnipoint::cli
