#include "cli/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <sstream>

namespace omnipoint::cli {

std::string clock_time(double seconds) {
  const long long total = std::llround(std::max(seconds, 0.0));
  char text[32];
  if (total >= 3600)
    std::snprintf(text, sizeof(text), "%lld:%02lld:%02lld", total / 3600, total / 60 % 60,
                  total % 60);
  else
    std::snprintf(text, sizeof(text), "%lld:%02lld", total / 60, total % 60);
  return text;
}

Progress::Progress(int64_t total)
    : total_(total),
      terminal_(isatty(STDERR_FILENO) == 1),
      started_(std::chrono::steady_clock::now()) {}

Progress::~Progress() {
  if (drawn_) std::cerr << "\n";
}

std::string Progress::prefix() const {
  if (terminal_ || total_ < 2) return "";
  return "[" + std::to_string(index_ + 1) + "/" + std::to_string(total_) + "] ";
}

void Progress::start(int64_t index, const std::string& name) {
  index_ = index;
  name_ = name;
  if (terminal_) draw();
}

void Progress::done() {
  ++completed_;
  if (terminal_) draw();
}

void Progress::line(const std::string& text) {
  clear();
  std::cerr << text << "\n";
  if (terminal_) draw();
}

void Progress::clear() {
  if (drawn_) std::cerr << "\r\033[K";
  drawn_ = false;
}

void Progress::draw() {
  constexpr int kWidth = 24;
  const double elapsed =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - started_).count();
  const int filled = static_cast<int>(kWidth * completed_ / std::max<int64_t>(total_, 1));
  std::ostringstream bar;
  bar << "\r\033[K[" << std::string(filled, '#') << std::string(kWidth - filled, '.') << "] "
      << completed_ << "/" << total_;
  if (completed_ > 0) {
    const double per_item = elapsed / completed_;
    bar << "  " << clock_time(elapsed) << " elapsed, "
        << clock_time(per_item * (total_ - completed_)) << " left";
  }
  // The name's tail (where file names differ), short enough for an 80-column terminal.
  if (completed_ < total_)
    bar << "  " << (name_.size() > 28 ? "..." + name_.substr(name_.size() - 25) : name_);
  std::cerr << bar.str() << std::flush;
  drawn_ = true;
}

}  // namespace omnipoint::cli
