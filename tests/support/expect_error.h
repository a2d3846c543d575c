#pragma once
// Error-message checks shared by the tests of parsers: bad input gets one clear line.
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

namespace omnipoint::test {

// Expects `action` to throw E whose message is one line containing every one of `parts`.
template <typename E>
void expect_error(const std::function<void()>& action, const std::vector<std::string>& parts) {
  try {
    action();
    ADD_FAILURE() << "no exception; expected one mentioning " << parts.front();
  } catch (const E& e) {
    const std::string message = e.what();
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
    for (const auto& part : parts) EXPECT_NE(message.find(part), std::string::npos) << message;
  }
}

}  // namespace omnipoint::test
