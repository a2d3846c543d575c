#pragma once
// What the reader tests of native layouts check an opening failure with: the error text of
// opening a dataset, and that a text holds a part.
#include <gtest/gtest.h>

#include <exception>
#include <string>

#include "omnipoint/data/dataset.h"

#define EXPECT_HAS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << (text) << " lacks " << (part)

namespace omnipoint::test {

// The message of opening `format` at `location`, or "(no error)".
inline std::string open_error(const std::string& format, const data::DatasetLocation& location) {
  try {
    data::open_dataset(format, location);
  } catch (const std::exception& error) {
    return error.what();
  }
  return "(no error)";
}

}  // namespace omnipoint::test
