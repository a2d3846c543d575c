#pragma once
// The median of a few numbers (the mean of the middle two for an even count), for the scale rules
// of the rig and sequence jobs. Empty input is the caller's to rule out.
#include <algorithm>
#include <cstddef>
#include <vector>

namespace omnipoint::predict {

inline double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  const std::size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : 0.5 * (values[n / 2 - 1] + values[n / 2]);
}

}  // namespace omnipoint::predict
