// libFuzzer target: rig_log_parser() of tests/fuzz/parsers.h, where the contract is.
#include "parsers.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const omnipoint::fuzz::Parser parser = omnipoint::fuzz::rig_log_parser();
  return omnipoint::fuzz::fuzz_one(parser, data, size);
}
