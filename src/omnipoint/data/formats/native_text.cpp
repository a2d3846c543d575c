#include "omnipoint/data/formats/native_text.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>
#include <vector>

namespace omnipoint::data::formats {
namespace {

[[noreturn]] void fail(const std::string& source, int line, const std::string& why) {
  throw std::runtime_error(source + (line > 0 ? ":" + std::to_string(line) : std::string()) + ": " +
                           why);
}

// A whole field as a finite number (std::stod accepts leading blanks and trailing text; we
// do not).
bool to_number(const std::string& text, double& value) {
  if (text.empty() || std::isspace(static_cast<unsigned char>(text.front()))) return false;
  std::size_t used = 0;
  try {
    value = std::stod(text, &used);
  } catch (const std::exception&) {
    return false;
  }
  return used == text.size() && std::isfinite(value);
}

double number(const std::string& text, const std::string& source, int line,
              const std::string& what) {
  double value = 0;
  if (!to_number(text, value)) fail(source, line, what + " \"" + text + "\" is not a number");
  return value;
}

// The whitespace-separated words of each non-blank line, with line numbers.
std::vector<std::pair<int, std::vector<std::string>>> word_lines(const std::string& text) {
  std::vector<std::pair<int, std::vector<std::string>>> lines;
  std::istringstream stream(text);
  int number = 0;
  for (std::string line; std::getline(stream, line);) {
    ++number;
    std::istringstream words(line);
    std::vector<std::string> fields;
    for (std::string word; words >> word;) fields.push_back(word);
    if (!fields.empty()) lines.emplace_back(number, std::move(fields));
  }
  return lines;
}

}  // namespace

Structured3dPose parse_structured3d_pose(const std::string& text, const std::string& source) {
  const auto lines = word_lines(text);
  if (lines.size() != 1 || lines.front().second.size() != 12)
    fail(source, 0, "expected one line of 12 numbers (vx vy vz tx ty tz ux uy uz xfov yfov 1)");
  const auto& [line, f] = lines.front();
  double v[12];
  for (int i = 0; i < 12; ++i) v[i] = number(f[i], source, line, "field " + std::to_string(i + 1));
  Structured3dPose pose;
  for (int i = 0; i < 3; ++i) {
    pose.eye[i] = v[i];
    pose.toward[i] = v[3 + i];
    pose.up[i] = v[6 + i];
  }
  pose.half_fov_x = v[9];
  pose.half_fov_y = v[10];
  const auto half_fov_ok = [](double angle) { return angle > 0 && angle < M_PI / 2; };
  if (!half_fov_ok(pose.half_fov_x) || !half_fov_ok(pose.half_fov_y))
    fail(source, line, "xfov and yfov must be half-angles in (0, pi/2) radians");
  return pose;
}

Pincam parse_pincam(const std::string& text, const std::string& source) {
  const auto lines = word_lines(text);
  if (lines.size() != 1 || lines.front().second.size() != 6)
    fail(source, 0, "expected one line of 6 numbers (width height fx fy cx cy)");
  const auto& [line, f] = lines.front();
  static const char* const names[] = {"width", "height", "fx", "fy", "cx", "cy"};
  double v[6];
  for (int i = 0; i < 6; ++i) v[i] = number(f[i], source, line, names[i]);
  for (int i = 0; i < 2; ++i)
    if (v[i] != std::floor(v[i]) || v[i] < 1 || v[i] > 100000)
      fail(source, line,
           std::string(names[i]) + " \"" + f[i] +
               "\" is not a whole number of pixels in [1, 100000]");
  if (v[2] <= 0 || v[3] <= 0) fail(source, line, "fx and fy must be positive");
  return {static_cast<int64_t>(v[0]), static_cast<int64_t>(v[1]), v[2], v[3], v[4], v[5]};
}

}  // namespace omnipoint::data::formats
