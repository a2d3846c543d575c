// util/config.h: a field table read, written and checked on a struct of every field kind, the
// exact one-line errors with their key paths, "extends" documents and --set overrides.
#include "omnipoint/util/config.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

namespace omnipoint::util {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

enum class Colour { kRed, kGreen };

struct Item {
  int64_t count = 2;
  std::vector<double> weights{1.0};
};

struct Options {
  bool flag = false;
  int small = 3;
  int64_t big = 7;
  uint64_t seed = 0;
  double rate = 0.5;
  std::string name = "x";
  Colour colour = Colour::kRed;
  std::array<int64_t, 2> size{4, 4};
  std::vector<std::string> tags;
  std::optional<int64_t> limit;
  Item item;
  std::vector<Item> items;
  int64_t width = 0, height = 0;  // "section": {"width", "height"}
  std::vector<int64_t> per_item;  // custom: one value for all items or one each
};

const ConfigTable<Item>& item_table() {
  static const ConfigTable<Item> table = [] {
    ConfigTable<Item> t;
    t.field("count", &Item::count).at_least(1);
    t.field("weights", &Item::weights).non_empty();
    return t;
  }();
  return table;
}

const ConfigTable<Options>& options_table() {
  static const ConfigTable<Options> table = [] {
    ConfigTable<Options> t;
    t.field("flag", &Options::flag);
    t.field("small", &Options::small);
    t.field("big", &Options::big).range(-10, 1000000000000);
    t.field("seed", &Options::seed);
    t.field("rate", &Options::rate).range(0.0, 1.0);
    t.field("name", &Options::name).non_empty();
    t.field("colour", &Options::colour,
            enum_codec<Colour>({{"red", Colour::kRed}, {"green", Colour::kGreen}}));
    t.field("size", &Options::size);
    t.field("tags", &Options::tags);
    t.field("limit", &Options::limit);
    t.field("item", &Options::item, struct_codec(item_table()));
    t.field("items", &Options::items, list_codec(struct_codec(item_table())));
    ConfigTable<Options>& section = t.section("section");
    section.field("width", &Options::width);
    section.field("height", &Options::height)
        .when([](const Options& o) { return o.width > 0; }, "a width");
    t.custom(
         "per_item",
         [](const json& value, Options& o, const ConfigScope& scope) {
           const auto codec = integer_codec<int64_t>();
           if (value.is_array())
             o.per_item = list_codec(codec).read(value, scope);
           else
             o.per_item.assign(o.items.size(), codec.read(value, scope));
         },
         [](const Options& o, json& out) { out = o.per_item; })
        .if_absent([](Options& o) { o.per_item.assign(o.items.size(), 1); });
    t.constant("kind", "options");
    t.rule([](const Options& o, const ConfigScope& scope) {
      if (o.per_item.size() != o.items.size())
        scope.key("per_item").fail("needs one value per item");
    });
    return t;
  }();
  return table;
}

Options read(const json& value) {
  return read_config(options_table(), value, "test");
}

json write(const Options& options) {
  json out;
  options_table().write(options, out);
  return out;
}

// The one-line message of reading `value`, or "" when it reads.
std::string error_of(const json& value) {
  try {
    read(value);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

json with(const std::string& key, const json& value) {
  return json{{key, value}};
}

TEST(ConfigTable, AbsentKeysKeepTheMemberInitialisers) {
  const Options options = read(json::object());
  EXPECT_FALSE(options.flag);
  EXPECT_EQ(options.small, 3);
  EXPECT_EQ(options.rate, 0.5);
  EXPECT_EQ(options.name, "x");
  EXPECT_EQ(options.colour, Colour::kRed);
  EXPECT_EQ(options.size, (std::array<int64_t, 2>{4, 4}));
  EXPECT_FALSE(options.limit);
  EXPECT_EQ(options.item.count, 2);
  EXPECT_TRUE(options.items.empty());
  EXPECT_TRUE(options.per_item.empty());  // if_absent: one per item, of none
}

TEST(ConfigTable, ReadWriteReadRoundTripsEveryKind) {
  const json text = json::parse(R"({
    "flag": true, "small": -4, "big": 1e4, "seed": 18446744073709551615, "rate": 0.25,
    "name": "run", "colour": "green", "size": [64, 48], "tags": ["a", "b"], "limit": 9,
    "item": {"count": 5}, "items": [{"count": 1, "weights": [0.5, 2]}, {}],
    "section": {"width": 3, "height": 2}, "kind": "options"})");
  const Options options = read(text);
  EXPECT_TRUE(options.flag);
  EXPECT_EQ(options.big, 10000);  // a float that is a whole number
  EXPECT_EQ(options.seed, 18446744073709551615u);
  EXPECT_EQ(options.colour, Colour::kGreen);
  EXPECT_EQ(options.limit, 9);
  EXPECT_EQ(options.item.weights, std::vector<double>{1.0});
  ASSERT_EQ(options.items.size(), 2u);
  EXPECT_EQ(options.items[1].count, 2);
  EXPECT_EQ(options.per_item, (std::vector<int64_t>{1, 1}));
  EXPECT_EQ(options.height, 2);

  const json written = write(options);
  EXPECT_EQ(written["colour"], "green");
  EXPECT_EQ(written["limit"], 9);
  EXPECT_EQ(written["kind"], "options");
  EXPECT_EQ(written["section"], (json{{"width", 3}, {"height", 2}}));
  EXPECT_EQ(written["items"][1], (json{{"count", 2}, {"weights", {1.0}}}));
  EXPECT_EQ(write(read(written)), written);

  Options none = options;
  none.limit.reset();
  none.width = 0;  // height no longer applies: not written
  const json again = write(none);
  EXPECT_TRUE(again["limit"].is_null());
  EXPECT_FALSE(again["section"].contains("height"));
  EXPECT_EQ(write(read(again)), again);
}

TEST(ConfigTable, ErrorsAreOneLineNamingTheKeyPath) {
  EXPECT_EQ(error_of(with("small", 1e300)),
            "test: small: expected an integer in range [-2147483648, 2147483647], got 1e+300");
  EXPECT_EQ(error_of(with("small", 1.5)),
            "test: small: expected an integer in range [-2147483648, 2147483647], got 1.5");
  EXPECT_EQ(error_of(with("small", "2")),
            "test: small: expected an integer in range [-2147483648, 2147483647], got \"2\"");
  EXPECT_EQ(error_of(with("small", 2147483648)),
            "test: small: expected an integer in range [-2147483648, 2147483647], got 2147483648");
  EXPECT_EQ(error_of(with("seed", -1)),
            "test: seed: expected an integer in range [0, 18446744073709551615], got -1");
  // 2^63 as a float and as an unsigned integer: beyond int64_t, never cast.
  EXPECT_EQ(error_of(with("big", 9.223372036854775808e18)),
            "test: big: expected an integer in range [-9223372036854775808, "
            "9223372036854775807], got 9.223372036854776e+18");
  EXPECT_EQ(error_of(with("big", 9223372036854775808u)),
            "test: big: expected an integer in range [-9223372036854775808, "
            "9223372036854775807], got 9223372036854775808");
  EXPECT_EQ(error_of(with("big", -11)), "test: big: must lie in [-10, 1000000000000]");
  EXPECT_EQ(error_of(with("flag", 1)), "test: flag: expected true or false, got 1");
  EXPECT_EQ(error_of(with("rate", "fast")), "test: rate: expected a finite number, got \"fast\"");
  EXPECT_EQ(error_of(with("rate", 2)), "test: rate: must lie in [0, 1]");
  EXPECT_EQ(error_of(with("name", "")), "test: name: must not be empty");
  EXPECT_EQ(error_of(with("colour", "blue")),
            "test: colour: expected one of red, green, got \"blue\"");
  EXPECT_EQ(error_of(with("size", {1})), "test: size: expected an array of 2 values, got [1]");
  EXPECT_EQ(error_of(with("size", {1, "a"})),
            "test: size[1]: expected an integer in range [-9223372036854775808, "
            "9223372036854775807], got \"a\"");
  EXPECT_EQ(error_of(with("tags", "a")), "test: tags: expected an array, got \"a\"");
  EXPECT_EQ(error_of(with("item", {{"bogus", 1}})),
            "test: item.bogus: unknown key (expected \"count\" or \"weights\")");
  EXPECT_EQ(error_of(with("item", 3)), "test: item: expected a JSON object, got 3");
  EXPECT_EQ(error_of(with("items", {json::object(), {{"count", 0}}})),
            "test: items[1].count: must be at least 1");
  EXPECT_EQ(error_of(with("items", {{{"weights", json::array()}}})),
            "test: items[0].weights: must not be empty");
  EXPECT_EQ(error_of(with("section", {{"height", 2}})), "test: section.height: only with a width");
  EXPECT_EQ(error_of(with("kind", "other")),
            "test: kind: only \"options\" is supported, got \"other\"");
  EXPECT_EQ(error_of({{"items", {json::object()}}, {"per_item", {1, 2}}}),
            "test: per_item: needs one value per item");
  EXPECT_EQ(error_of(json::array()), "test: expected a JSON object, got []");
  const std::string unknown = error_of(with("bogus", 1));
  EXPECT_EQ(unknown.rfind("test: bogus: unknown key (expected \"flag\", \"small\", ", 0), 0)
      << unknown;
  // A huge value is cut in the message, which stays one line.
  const std::string huge = error_of(with("flag", std::string(500, 'x')));
  EXPECT_LT(huge.size(), 120u);
  EXPECT_EQ(huge.find('\n'), std::string::npos);
}

TEST(ConfigTable, CheckConfigRunsTheSameChecksOnABuiltStruct) {
  Options options;
  EXPECT_NO_THROW(check_config(options_table(), options, "built"));
  options.items.resize(1);
  options.items[0].count = 0;
  options.per_item = {1};
  try {
    check_config(options_table(), options, "built");
    FAIL() << "a count of 0 passed";
  } catch (const ConfigError& e) {
    EXPECT_EQ(std::string(e.what()), "built: items[0].count: must be at least 1");
  }
}

struct Choice {
  std::string a, b;
  int64_t value = 0;
};

TEST(ConfigTable, RequiredExclusiveAndLenientTables) {
  ConfigTable<Choice> t;
  t.field("a", &Choice::a);
  t.field("b", &Choice::b);
  t.field("value", &Choice::value).required("required: the value");
  t.exactly_one_of({"a", "b"});
  const auto error = [&](const json& value) {
    try {
      read_config(t, value, "choice");
    } catch (const ConfigError& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_EQ(error({{"a", "x"}}), "choice: value: required: the value");
  EXPECT_EQ(error({{"value", 1}}), "choice: needs exactly one of \"a\" or \"b\"");
  EXPECT_EQ(error({{"value", 1}, {"a", "x"}, {"b", "y"}}),
            "choice: needs exactly one of \"a\" or \"b\"");
  EXPECT_EQ(error({{"value", 1}, {"a", "x"}}), "");
  EXPECT_EQ(error({{"value", 1}, {"a", "x"}, {"c", 1}}),
            "choice: c: unknown key (expected \"a\", \"b\" or \"value\")");
  t.ignore_unknown_keys();  // MoGe-2's **kwargs
  EXPECT_EQ(error({{"value", 1}, {"a", "x"}, {"c", 1}}), "");
}

// ---------------------------------------------------------------------------------------------
// Documents: "extends" and --set

class ConfigFiles : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("omnipoint_config_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "sub");
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name) << text;
    return (dir_ / name).string();
  }
  std::string error_of(const std::string& path) {
    try {
      read_config_file(path);
    } catch (const std::exception& e) {
      return e.what();
    }
    return "";
  }
  fs::path dir_;
};

TEST_F(ConfigFiles, ExtendsMergesAChainRelativeToEachFile) {
  file("base.json", R"({"a": 1, "o": {"x": 1, "y": [1, 2], "z": {"k": 1}}, "list": [1, 2, 3],
                        "gone": {"p": 1}})");
  file("sub/middle.json", R"({"extends": "../base.json", "o": {"y": [3]}, "b": 2})");
  const std::string top = file("sub/top.json", R"({"extends": "middle.json",
      "o": {"x": null, "z": {"m": 2}}, "list": [4], "gone": null, "a": "one"})");
  EXPECT_EQ(read_config_file(top), json::parse(R"({"a": "one", "b": 2,
      "o": {"y": [3], "z": {"k": 1, "m": 2}}, "list": [4]})"));
  // No "extends": the file as it is.
  EXPECT_EQ(read_config_file((dir_ / "base.json").string())["a"], 1);
}

TEST_F(ConfigFiles, CyclesMissingBasesAndBadExtendsNameTheFiles) {
  const std::string a = file("a.json", R"({"extends": "sub/b.json", "x": 1})");
  file("sub/b.json", R"({"extends": "../a.json"})");
  EXPECT_EQ(error_of(a), "config " + a + ": \"extends\" forms a cycle: " + a + " -> " +
                             (dir_ / "sub/b.json").string() + " -> " +
                             (dir_ / "sub/../a.json").string());
  const std::string self = file("self.json", R"({"extends": "self.json"})");
  EXPECT_NE(error_of(self).find("forms a cycle"), std::string::npos) << error_of(self);

  const std::string orphan = file("orphan.json", R"({"extends": "none.json"})");
  EXPECT_EQ(error_of(orphan), "config " + orphan + ": extends \"none.json\": " +
                                  (dir_ / "none.json").string() + ": cannot open for reading");
  const std::string number = file("number.json", R"({"extends": 3})");
  EXPECT_EQ(error_of(number), "config " + number + ": \"extends\" must be a file name, got 3");
  const std::string broken = file("broken.json", R"({"extends": "bad.json"})");
  file("bad.json", "{");
  EXPECT_EQ(
      error_of(broken).rfind("config " + (dir_ / "bad.json").string() + ": not valid JSON", 0), 0u)
      << error_of(broken);
  EXPECT_EQ(error_of((dir_ / "nothing.json").string()),
            (dir_ / "nothing.json").string() + ": cannot open for reading");
}

std::string override_error(json document, const std::string& assignment) {
  try {
    apply_config_override(document, assignment);
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

TEST(ConfigOverride, SetsNestedKeysAndArrayEntries) {
  json document = json::parse(R"({"stages": [{"steps": 1}, {"steps": 2}], "data": {"n": 1}})");
  apply_config_override(document, "stages[1].steps=2000");
  apply_config_override(document, "stages.0.steps=1e4");
  apply_config_override(document, "data.size=[64, 48]");
  apply_config_override(document, "augment.flip=true");  // created on the way
  apply_config_override(document, "output_dir=runs/b");  // not JSON: a string
  apply_config_override(document, "name=\"7\"");         // a JSON string
  apply_config_override(document, "data.n=null");        // deleted: its default applies
  apply_config_override(document, "equation=a=b");       // the first '=' splits
  EXPECT_EQ(document, json::parse(R"({"stages": [{"steps": 1e4}, {"steps": 2000}],
      "data": {"size": [64, 48]}, "augment": {"flip": true}, "output_dir": "runs/b",
      "name": "7", "equation": "a=b"})"));

  const json base = json::parse(R"({"stages": [{"steps": 1}], "seed": 3})");
  EXPECT_EQ(override_error(base, "stages[1].steps=5"),
            "--set stages[1].steps=5: stages has 1 entries");
  EXPECT_EQ(override_error(base, "stages.x=5"),
            "--set stages.x=5: stages is an array (index it as [i] or .i)");
  EXPECT_EQ(override_error(base, "seed.value=5"), "--set seed.value=5: seed is 3, not an object");
  EXPECT_EQ(override_error(base, "data[0]=5"), "--set data[0]=5: data is not an array");
  EXPECT_EQ(override_error(base, "seed"), "--set seed: expected KEY=VALUE");
  EXPECT_EQ(override_error(base, "=5"), "--set =5: an empty key");
  EXPECT_EQ(override_error(base, "a..b=5"), "--set a..b=5: an empty key");
  EXPECT_EQ(override_error(base, "stages[x]=5"),
            "--set stages[x]=5: expected an index in [], got \"x\"");
  EXPECT_EQ(override_error(base, "stages[0=5"), "--set stages[0=5: unclosed '['");
  EXPECT_EQ(override_error(base, "stages[0]x=5"),
            "--set stages[0]x=5: expected '.' or '[' after \"stages[0]\"");
  EXPECT_EQ(override_error(base, "stages[99999999999999999999999].steps=5"),
            "--set stages[99999999999999999999999].steps=5: stages has 1 entries");
}

// An override reaches the typed read like any key: an unknown or mistyped key is its error.
TEST(ConfigOverride, TheTypedReadChecksOverriddenKeys) {
  const json empty = json::object();
  EXPECT_EQ(override_error(empty, "items[0]=5"), "--set items[0]=5: items is not an array");
  json untouched = empty;  // a failed override changes nothing
  EXPECT_THROW(apply_config_override(untouched, "a.b[0]=5"), std::invalid_argument);
  EXPECT_EQ(untouched, empty);
  json typed = json::object();
  apply_config_override(typed, "item.count=0");
  EXPECT_EQ(error_of(typed), "test: item.count: must be at least 1");
  apply_config_override(typed, "item.colour=red");
  EXPECT_EQ(error_of(typed), "test: item.colour: unknown key (expected \"count\" or \"weights\")");
}

}  // namespace
}  // namespace omnipoint::util
