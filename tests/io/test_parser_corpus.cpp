// Replays the fuzzing seed corpus, the hand-made malformed files and any fuzzer findings
// (tests/fuzz/, see docs/FUZZING.md) through the fuzzed parsers (tests/fuzz/parsers.h), so
// the error paths the fuzzers explore stay covered without clang. A file's parser is named by
// its first folder: corpus/ply/..., malformed/ply/..., regressions/ply/...
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <sstream>
#include <string>

#include "fuzz/parsers.h"
#include "omnipoint/io/atomic_file.h"

namespace fs = std::filesystem;
using omnipoint::fuzz::Parser;

namespace {

const fs::path kFuzzDir = fs::path(OMNIPOINT_SOURCE_DIR) / "tests" / "fuzz";

std::vector<fs::path> files_under(const fs::path& dir) {
  std::vector<fs::path> out;
  if (!fs::is_directory(dir)) return out;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    if (entry.is_regular_file() && entry.path().filename() != "expected_errors.txt")
      out.push_back(entry.path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The parser of `file` under `root`, by the first folder of its relative path.
const Parser& parser_of(const fs::path& file, const fs::path& root) {
  return omnipoint::fuzz::parser_named(fs::relative(file, root).begin()->string());
}

// Every parser's entry points under the contract: the file's own and, as other bytes they
// never expect, everyone else's.
void run_every_parser(const fs::path& file) {
  const std::string bytes = omnipoint::io::read_file(file.string());
  for (const Parser& parser : omnipoint::fuzz::parsers()) {
    SCOPED_TRACE(parser.name);
    omnipoint::fuzz::run_all(parser, bytes, file.string());
  }
}

}  // namespace

TEST(ParserCorpus, EveryParserHasSeedsAndMalformedFiles) {
  for (const Parser& parser : omnipoint::fuzz::parsers()) {
    EXPECT_GE(files_under(kFuzzDir / "corpus" / parser.name).size(), 2u) << parser.name;
    EXPECT_GE(files_under(kFuzzDir / "malformed" / parser.name).size(), 3u) << parser.name;
  }
}

TEST(ParserCorpus, SeedsParseWithTheirParserAndNeverCrashTheOthers) {
  const auto seeds = files_under(kFuzzDir / "corpus");
  ASSERT_GE(seeds.size(), 30u);
  for (const fs::path& file : seeds) {
    SCOPED_TRACE(file.string());
    const Parser& parser = parser_of(file, kFuzzDir / "corpus");
    EXPECT_NO_THROW(parser.parse(omnipoint::io::read_file(file.string()), file.string()));
    run_every_parser(file);
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
    const Parser& parser = parser_of(file, kFuzzDir / "malformed");
    const auto check = [&](const std::exception& e) {
      EXPECT_NE(std::string(e.what()).find(expected[key]), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    };
    try {
      parser.parse(omnipoint::io::read_file(file.string()), file.string());
      ADD_FAILURE() << "parsed without error";
    } catch (const std::runtime_error& e) {
      check(e);
    } catch (const std::invalid_argument& e) {
      EXPECT_FALSE(parser.runtime_error_only) << e.what();
      check(e);
    }
    run_every_parser(file);
  }
}

// Inputs the fuzzers once crashed on (tests/fuzz/regressions/<parser>/), through every parser.
TEST(ParserCorpus, FuzzerFindingsStayFixed) {
  for (const fs::path& file : files_under(kFuzzDir / "regressions")) {
    SCOPED_TRACE(file.string());
    parser_of(file, kFuzzDir / "regressions");  // the folder names a parser
    run_every_parser(file);
  }
}
