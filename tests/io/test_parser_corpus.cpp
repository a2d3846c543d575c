// Replays the fuzzing seed corpus, the hand-made malformed files and any fuzzer findings
// (tests/fuzz/, see docs/FUZZING.md) through both file parsers, so the error paths the
// fuzzers explore stay covered without clang.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/safetensors.h"

namespace fs = std::filesystem;

namespace {

const fs::path kFuzzDir = fs::path(OMNIPOINT_SOURCE_DIR) / "tests" / "fuzz";

// The parser for a file, chosen by its folder: safetensors/ or npy/.
bool is_safetensors(const fs::path& file) {
  return file.parent_path().filename() == "safetensors";
}

void parse(const fs::path& file, bool as_safetensors) {
  const std::string bytes = omnipoint::io::read_file(file.string());
  if (as_safetensors) {
    omnipoint::io::parse_safetensors(bytes.data(), bytes.size(), file.string());
  } else {
    omnipoint::io::parse_npy(bytes.data(), bytes.size(), file.string());
  }
}

// Either parses or throws std::runtime_error; anything else (another exception type, a
// crash) fails the test.
void expect_parsed_or_rejected(const fs::path& file, bool as_safetensors) {
  try {
    parse(file, as_safetensors);
  } catch (const std::runtime_error&) {
  }
}

std::vector<fs::path> files_under(const fs::path& dir) {
  std::vector<fs::path> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().extension() != ".txt") out.push_back(entry.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace

TEST(ParserCorpus, SeedsParseWithTheirParserAndNeverCrashTheOther) {
  const auto seeds = files_under(kFuzzDir / "corpus");
  ASSERT_GE(seeds.size(), 10u);
  for (const fs::path& file : seeds) {
    SCOPED_TRACE(file.string());
    EXPECT_NO_THROW(parse(file, is_safetensors(file)));
    expect_parsed_or_rejected(file, !is_safetensors(file));
  }
}

TEST(ParserCorpus, MalformedFilesFailWithTheirMessage) {
  std::map<std::string, std::string> expected;  // relative path -> message fragment
  std::istringstream lines(
      omnipoint::io::read_file((kFuzzDir / "malformed" / "expected_errors.txt").string()));
  for (std::string line; std::getline(lines, line);) {
    if (line.empty() || line[0] == '#') continue;
    const std::size_t tab = line.find('\t');
    ASSERT_NE(tab, std::string::npos) << line;
    expected[line.substr(0, tab)] = line.substr(tab + 1);
  }
  const auto files = files_under(kFuzzDir / "malformed");
  EXPECT_EQ(files.size(), expected.size())
      << "every malformed file needs a line in expected_errors.txt";
  for (const fs::path& file : files) {
    SCOPED_TRACE(file.string());
    const std::string key = fs::relative(file, kFuzzDir / "malformed").string();
    ASSERT_EQ(expected.count(key), 1u) << key << " is not in expected_errors.txt";
    try {
      parse(file, is_safetensors(file));
      ADD_FAILURE() << "parsed without error";
    } catch (const std::runtime_error& e) {
      EXPECT_NE(std::string(e.what()).find(expected[key]), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
    expect_parsed_or_rejected(file, !is_safetensors(file));
  }
}

// Inputs the fuzzers once crashed on (tests/fuzz/regressions/{safetensors,npy}/).
TEST(ParserCorpus, FuzzerFindingsStayFixed) {
  for (const fs::path& file : files_under(kFuzzDir / "regressions")) {
    SCOPED_TRACE(file.string());
    expect_parsed_or_rejected(file, true);
    expect_parsed_or_rejected(file, false);
  }
}
