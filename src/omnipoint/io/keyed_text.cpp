#include "omnipoint/io/keyed_text.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace omnipoint::io {

KeyedText KeyedText::parse(const std::string& text, const std::string& name) {
  KeyedText keyed;
  keyed.name_ = name;
  std::istringstream lines(text);
  for (std::string line; std::getline(lines, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::size_t colon = line.find(':');
    std::istringstream words(line.substr(0, colon));
    std::string key, extra;
    words >> key;
    if (key.empty() && colon == std::string::npos) continue;
    if (colon == std::string::npos || key.empty() || (words >> extra))
      throw std::invalid_argument(name + ": the line \"" + line.substr(0, 80) +
                                  "\" is not \"KEY: values\" (a KITTI calibration file)");
    if (keyed.has(key)) throw std::invalid_argument(name + ": the key " + key + " appears twice");
    keyed.entries_.emplace_back(key, line.substr(colon + 1));
  }
  return keyed;
}

bool KeyedText::has(const std::string& key) const {
  return std::any_of(entries_.begin(), entries_.end(),
                     [&](const auto& entry) { return entry.first == key; });
}

std::vector<std::string> KeyedText::keys() const {
  std::vector<std::string> keys;
  for (const auto& entry : entries_) keys.push_back(entry.first);
  return keys;
}

std::vector<double> KeyedText::numbers(const std::string& key, std::size_t count) const {
  const auto entry =
      std::find_if(entries_.begin(), entries_.end(), [&](const auto& e) { return e.first == key; });
  if (entry == entries_.end()) throw std::invalid_argument(name_ + ": no key " + key);
  std::istringstream words(entry->second);
  std::vector<double> values;
  for (std::string token; words >> token;) {
    std::size_t used = 0;
    double value = 0;
    try {
      value = std::stod(token, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != token.size() || !std::isfinite(value))
      throw std::invalid_argument(name_ + " " + key + ": \"" + token.substr(0, 40) +
                                  "\" is not a number");
    values.push_back(value);
  }
  if (count > 0 && values.size() != count)
    throw std::invalid_argument(name_ + ": " + key + ": expected " + std::to_string(count) +
                                " numbers, got " + std::to_string(values.size()));
  return values;
}

}  // namespace omnipoint::io
