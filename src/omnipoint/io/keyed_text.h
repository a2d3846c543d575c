#pragma once
// Calibration text of KITTI's devkits: one entry a line, "KEY: values", the values numbers
// separated by spaces (calib_time and the like hold words). Read by KITTI raw
// (calib_cam_to_cam.txt, calib_velo_to_cam.txt), KITTI odometry (calib.txt) and KITTI-360
// (calib_cam_to_pose.txt, perspective.txt). Blank lines are skipped; a line without a key and a
// colon, or a key given twice, is an error. Errors are std::invalid_argument "NAME: problem",
// NAME as the caller passes it (the file, with what it is for).
#include <cstddef>
#include <string>
#include <utility>
#include <vector>

namespace omnipoint::io {

class KeyedText {
 public:
  static KeyedText parse(const std::string& text, const std::string& name);

  bool has(const std::string& key) const;
  // The keys in file order.
  std::vector<std::string> keys() const;
  // The numbers of `key`: a missing key or a value that is not a number is an error naming the
  // key; with `count` > 0 the count must match too.
  std::vector<double> numbers(const std::string& key, std::size_t count = 0) const;

 private:
  std::string name_;
  std::vector<std::pair<std::string, std::string>> entries_;  // key -> the text after ':'
};

}  // namespace omnipoint::io
