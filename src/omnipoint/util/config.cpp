#include "omnipoint/util/config.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

namespace omnipoint::util {

using nlohmann::json;

ConfigScope ConfigScope::key(const std::string& key) const {
  return ConfigScope(path_.empty() ? key : path_ + "." + key);
}

ConfigScope ConfigScope::index(std::size_t index) const {
  return ConfigScope(path_ + "[" + std::to_string(index) + "]");
}

void ConfigScope::fail(const std::string& problem) const {
  throw ConfigError(path_.empty() ? problem : path_ + ": " + problem);
}

std::string config_number(double value) {
  char text[32];
  std::snprintf(text, sizeof(text), "%.10g", value);
  return text;
}

void with_document(const std::string& document, const std::function<void()>& call) {
  try {
    call();
  } catch (const ConfigError& e) {
    throw ConfigError(document + ": " + e.what());
  }
}

namespace config_json {

const json& empty_object() {
  static const json kEmpty = json::object();
  return kEmpty;
}

bool is_null(const json& value) {
  return value.is_null();
}

std::string short_text(const json& value) {
  std::string text = value.dump(-1, ' ', false, json::error_handler_t::replace);
  constexpr std::size_t kMax = 60;
  if (text.size() <= kMax) return text;
  std::size_t cut = kMax;
  while (cut > 0 && (static_cast<unsigned char>(text[cut]) & 0xC0) == 0x80) --cut;  // UTF-8
  return text.substr(0, cut) + "...";
}

std::size_t array_size(const json& value, const ConfigScope& scope) {
  if (!value.is_array()) scope.fail("expected an array, got " + short_text(value));
  return value.size();
}

const json& array_item(const json& value, std::size_t index) {
  return value[index];
}

void make_array(json& value) {
  if (value.is_null()) value = json::array();
}

void make_object(json& value) {
  if (value.is_null()) value = json::object();
}

json& append(json& value) {
  value.push_back(nullptr);
  return value.back();
}

json& member(json& value, const std::string& key) {
  make_object(value);
  return value[key];
}

const json* find(const json& object, const std::string& key) {
  const auto it = object.find(key);
  return it == object.end() ? nullptr : &*it;
}

std::vector<std::string> object_keys(const json& value, const ConfigScope& scope) {
  if (!value.is_object()) scope.fail("expected a JSON object, got " + short_text(value));
  std::vector<std::string> keys;
  for (const auto& item : value.items()) keys.push_back(item.key());
  return keys;
}

void set_null(json& value) {
  value = nullptr;
}
void set_text(json& value, const std::string& text) {
  value = text;
}
void set_integer(json& value, int64_t number) {
  value = number;
}
void set_unsigned(json& value, uint64_t number) {
  value = number;
}

std::string read_text(const json& value, const ConfigScope& scope) {
  if (!value.is_string()) scope.fail("expected a string, got " + short_text(value));
  return value.get<std::string>();
}

void expect_text(const json& value, const std::string& text, const ConfigScope& scope) {
  if (!value.is_string() || value.get<std::string>() != text)
    scope.fail("only \"" + text + "\" is supported, got " + short_text(value));
}

void expect_integer(const json& value, int64_t number, const ConfigScope& scope) {
  if (!value.is_number() || value != json(number))
    scope.fail("only " + std::to_string(number) + " is supported, got " + short_text(value));
}

namespace {

[[noreturn]] void not_an_integer(const json& value, const std::string& range,
                                 const ConfigScope& scope) {
  scope.fail("expected an integer in range " + range + ", got " + short_text(value));
}

// Whether `d` is a whole number that converts to int64_t (signed) or uint64_t exactly: nlohmann's
// get<T>() casts whatever it finds, and casting an out-of-range float to an integer is
// undefined behaviour. (1e4 is a fine step count.)
bool whole(double d, bool is_signed) {
  return std::isfinite(d) && d == std::trunc(d) && d >= (is_signed ? -0x1p63 : 0.0) &&
         d < (is_signed ? 0x1p63 : 0x1p64);
}

}  // namespace

int64_t read_integer(const json& value, int64_t min, int64_t max, const ConfigScope& scope) {
  const std::string range = "[" + std::to_string(min) + ", " + std::to_string(max) + "]";
  int64_t number = 0;
  if (value.is_number_unsigned()) {
    const auto u = value.get<uint64_t>();
    if (u > static_cast<uint64_t>(std::numeric_limits<int64_t>::max()))
      not_an_integer(value, range, scope);
    number = static_cast<int64_t>(u);
  } else if (value.is_number_integer()) {
    number = value.get<int64_t>();
  } else if (value.is_number_float() && whole(value.get<double>(), true)) {
    number = static_cast<int64_t>(value.get<double>());
  } else {
    not_an_integer(value, range, scope);
  }
  if (number < min || number > max) not_an_integer(value, range, scope);
  return number;
}

uint64_t read_unsigned(const json& value, uint64_t max, const ConfigScope& scope) {
  const std::string range = "[0, " + std::to_string(max) + "]";
  uint64_t number = 0;
  if (value.is_number_unsigned()) {
    number = value.get<uint64_t>();
  } else if (value.is_number_integer() && value.get<int64_t>() >= 0) {
    number = static_cast<uint64_t>(value.get<int64_t>());
  } else if (value.is_number_float() && whole(value.get<double>(), false)) {
    number = static_cast<uint64_t>(value.get<double>());
  } else {
    not_an_integer(value, range, scope);
  }
  if (number > max) not_an_integer(value, range, scope);
  return number;
}

}  // namespace config_json

ConfigCodec<bool> bool_codec() {
  ConfigCodec<bool> codec;
  codec.read = [](const json& value, const ConfigScope& scope) {
    if (!value.is_boolean())
      scope.fail("expected true or false, got " + config_json::short_text(value));
    return value.get<bool>();
  };
  codec.write = [](const bool& value, json& out) { out = value; };
  return codec;
}

ConfigCodec<double> double_codec() {
  ConfigCodec<double> codec;
  codec.read = [](const json& value, const ConfigScope& scope) {
    const double number = value.is_number() ? value.get<double>() : NAN;
    if (!std::isfinite(number))
      scope.fail("expected a finite number, got " + config_json::short_text(value));
    return number;
  };
  codec.write = [](const double& value, json& out) { out = value; };
  return codec;
}

ConfigCodec<std::string> string_codec() {
  ConfigCodec<std::string> codec;
  codec.read = config_json::read_text;
  codec.write = [](const std::string& value, json& out) { out = value; };
  return codec;
}

// ---------------------------------------------------------------------------------------------
// Documents

void merge_config(json& target, const json& patch) {
  if (!patch.is_object()) {
    target = patch;
    return;
  }
  if (!target.is_object()) target = json::object();
  for (const auto& [key, value] : patch.items()) {
    if (value.is_null())
      target.erase(key);
    else
      merge_config(target[key], value);
  }
}

namespace {

namespace fs = std::filesystem;

// The same file under every spelling of its path (for cycles).
std::string identity(const fs::path& path) {
  std::error_code error;
  const fs::path canonical = fs::weakly_canonical(path, error);
  return (error ? fs::absolute(path).lexically_normal() : canonical).string();
}

json read_with_bases(const fs::path& path, std::vector<std::string>& chain,
                     std::vector<std::string>& names) {
  const std::string name = path.string();
  const std::string id = identity(path);
  if (std::find(chain.begin(), chain.end(), id) != chain.end()) {
    std::string cycle;
    for (const std::string& file : names) cycle += file + " -> ";
    throw std::invalid_argument("config " + names.front() +
                                ": \"extends\" forms a cycle: " + cycle + name);
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(name + ": cannot open for reading");
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw std::runtime_error(name + ": read failed");
  json document;
  try {
    document = json::parse(text.str());
  } catch (const json::exception& e) {
    throw std::invalid_argument("config " + name + ": not valid JSON (" + e.what() + ")");
  }
  if (!document.is_object() || !document.contains("extends")) return document;
  const json& extends = document["extends"];
  if (!extends.is_string())
    throw std::invalid_argument("config " + name + ": \"extends\" must be a file name, got " +
                                config_json::short_text(extends));
  const std::string base_name = extends.get<std::string>();
  chain.push_back(id);
  names.push_back(name);
  json base;
  try {
    base = read_with_bases(path.parent_path() / base_name, chain, names);
  } catch (const std::runtime_error& e) {  // the base cannot be read: name who names it
    throw std::runtime_error("config " + name + ": extends \"" + base_name + "\": " + e.what());
  }
  chain.pop_back();
  names.pop_back();
  document.erase("extends");
  merge_config(base, document);
  return base;
}

struct PathStep {
  std::string key;     // an object key, or the digits of an index
  bool index = false;  // written [i]: an array index only
};

[[noreturn]] void bad_override(const std::string& assignment, const std::string& problem) {
  throw std::invalid_argument("--set " + assignment + ": " + problem);
}

std::vector<PathStep> parse_key_path(const std::string& path, const std::string& assignment) {
  const auto fail = [&](const std::string& problem) { bad_override(assignment, problem); };
  std::vector<PathStep> steps;
  std::size_t at = 0;
  bool expect_key = true;
  while (at < path.size()) {
    if (path[at] == '[') {
      const std::size_t close = path.find(']', at);
      if (close == std::string::npos) fail("unclosed '['");
      const std::string digits = path.substr(at + 1, close - at - 1);
      if (digits.empty() || digits.find_first_not_of("0123456789") != std::string::npos)
        fail("expected an index in [], got \"" + digits + "\"");
      steps.push_back({digits, true});
      at = close + 1;
      expect_key = false;
      continue;
    }
    if (path[at] == '.') {
      if (expect_key) fail("an empty key");
      ++at;
      expect_key = true;
      continue;
    }
    if (!expect_key) fail("expected '.' or '[' after \"" + path.substr(0, at) + "\"");
    const std::size_t end = path.find_first_of(".[", at);
    steps.push_back({path.substr(at, end == std::string::npos ? std::string::npos : end - at)});
    at = end == std::string::npos ? path.size() : end;
    expect_key = false;
  }
  if (steps.empty() || expect_key) fail("an empty key");
  return steps;
}

}  // namespace

json read_config_file(const std::string& path) {
  std::vector<std::string> chain, names;
  return read_with_bases(fs::path(path), chain, names);
}

void apply_config_override(json& document, const std::string& assignment) {
  const std::size_t equals = assignment.find('=');
  if (equals == std::string::npos) bad_override(assignment, "expected KEY=VALUE");
  const std::string path = assignment.substr(0, equals), text = assignment.substr(equals + 1);
  const std::vector<PathStep> steps = parse_key_path(path, assignment);
  json value = json::parse(text, nullptr, false);
  if (value.is_discarded()) value = text;  // a plain string: --set output_dir=runs/b
  if (!document.is_object()) bad_override(assignment, "the config is not a JSON object");

  json result = document;  // `document` stays as it was if the override fails
  json* at = &result;
  std::string where;  // the path so far, for messages
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const PathStep& step = steps[i];
    const bool last = i + 1 == steps.size();
    const bool digits = step.key.find_first_not_of("0123456789") == std::string::npos;
    if (at->is_array()) {
      if (!digits) bad_override(assignment, where + " is an array (index it as [i] or .i)");
      // Digits only: at most 19 of them fit; longer ones are out of range anyway.
      const std::size_t index = step.key.size() > 18 ? at->size() : std::stoull(step.key);
      if (index >= at->size())
        bad_override(assignment, where + " has " + std::to_string(at->size()) + " entries");
      where += "[" + step.key + "]";
      if (last) {
        (*at)[index] = value;
        break;
      }
      at = &(*at)[index];
      continue;
    }
    if (step.index)
      bad_override(assignment,
                   (where.empty() ? std::string("the config") : where) + " is not an array");
    if (!at->is_object() && !at->is_null())
      bad_override(assignment, where + " is " + config_json::short_text(*at) + ", not an object");
    where += (where.empty() ? "" : ".") + step.key;
    if (last) {
      if (value.is_null()) {  // as in "extends": null deletes (the key's default applies)
        if (at->is_object()) at->erase(step.key);
      } else {
        (*at)[step.key] = value;
      }
      break;
    }
    at = &(*at)[step.key];
  }
  document = std::move(result);
}

}  // namespace omnipoint::util
