// libFuzzer target: parse_npy on arbitrary bytes. The contract is "parse, or throw
// std::runtime_error"; any other exception, crash, leak or sanitizer report is a finding.
#include <cstddef>
#include <cstdint>
#include <stdexcept>

#include "omnipoint/io/npy.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    omnipoint::io::parse_npy(reinterpret_cast<const char*>(data), size, "fuzz");
  } catch (const std::runtime_error&) {
  }
  return 0;
}
