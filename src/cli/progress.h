#pragma once
// Progress of a loop over items on stderr: on a terminal one bar redrawn in place with the count,
// the rate and the time left; otherwise (a log file, a pipe) one plain line per item, so logs
// stay readable. Messages about an item go through `line` so they do not tear the bar.
#include <chrono>
#include <cstdint>
#include <string>

namespace omnipoint::cli {

// Seconds as M:SS, or H:MM:SS from an hour on (rounded; negative as 0).
std::string clock_time(double seconds);

class Progress {
 public:
  explicit Progress(int64_t total);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  // Item `index` (0-based) starts: redraws the bar (terminal) with its name.
  void start(int64_t index, const std::string& name);
  // A message line (the bar is cleared and redrawn below it).
  void line(const std::string& text);
  // Item done (counts towards the rate and the estimate).
  void done();
  // "[i/N] " on plain output for several items (the prefix of an item's lines); "" otherwise.
  std::string prefix() const;

 private:
  void draw();
  void clear();

  int64_t total_;
  int64_t index_ = 0;
  int64_t completed_ = 0;
  std::string name_;
  bool terminal_;
  bool drawn_ = false;
  std::chrono::steady_clock::time_point started_;
};

}  // namespace omnipoint::cli
