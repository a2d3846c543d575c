#include "omnipoint/data/moge_format.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "omnipoint/data/png_text.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"

namespace omnipoint::data {
namespace fs = std::filesystem;

namespace {
constexpr double kSteps = 65533.0;

std::string shortest(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.17g", v);
  return buf;
}
}  // namespace

MogeDepthCode encode_moge_depth(const at::Tensor& depth_in, double max_range) {
  if (depth_in.dim() != 2 || !at::isFloatingType(depth_in.scalar_type()))
    throw std::invalid_argument("encode_moge_depth: depth must be a floating (H, W) tensor");
  const auto depth = depth_in.to(at::kCPU, at::kDouble);
  const auto finite = at::isfinite(depth);
  if (!finite.any().item<bool>())
    throw std::invalid_argument("encode_moge_depth: no finite depth value to encode");
  if ((depth.masked_select(finite) <= 0).any().item<bool>() ||
      (depth == -INFINITY).any().item<bool>())
    throw std::invalid_argument(
        "encode_moge_depth: depth values must be positive (NaN unknown, +inf infinity)");
  const auto values = depth.masked_select(finite);
  MogeDepthCode code;
  code.near = std::max(values.min().item<double>(), 1e-5);
  code.far =
      std::max(code.near * 1.1, std::min(values.max().item<double>(), code.near * max_range));
  const auto clipped =
      at::where(finite, depth, at::full_like(depth, code.near)).clamp(code.near, code.far);
  const auto t = (at::log(clipped / code.near) / std::log(code.far / code.near)).clamp(0, 1);
  auto v = (1 + at::round(t * kSteps)).to(at::kInt);
  v = at::where(at::isnan(depth), at::zeros_like(v), v);
  v = at::where(at::isinf(depth), at::full_like(v, 65535), v);
  code.values = v;
  return code;
}

at::Tensor decode_moge_depth(const MogeDepthCode& code) {
  const auto v = code.values.to(at::kDouble);
  const auto t = (v - 1) / kSteps;
  auto depth = code.near * at::exp(t * std::log(code.far / code.near));
  depth = at::where(v == 0, at::full_like(depth, std::numeric_limits<double>::quiet_NaN()), depth);
  depth = at::where(v == 65535, at::full_like(depth, INFINITY), depth);
  return depth.to(at::kFloat);
}

void write_moge_depth(const std::string& path, const at::Tensor& depth) {
  const auto code = encode_moge_depth(depth);
  io::write_image_png(path, code.values);
  const auto png = add_png_text(io::read_file(path),
                                {{"near", shortest(code.near)}, {"far", shortest(code.far)}});
  io::write_file_atomically(path, [&](std::ostream& out) { out.write(png.data(), png.size()); });
}

MogeDepthRange parse_moge_depth_range(const std::string& png, const std::string& name) {
  const auto text = read_png_text(png, name);
  const auto number = [&](const char* key, bool required) {
    const auto it = text.find(key);
    if (it == text.end()) {
      if (!required) return 1.0;
      throw std::runtime_error(name + ": no '" + key + "' text chunk (not a MoGe depth PNG)");
    }
    try {
      std::size_t used = 0;
      const double value = std::stod(it->second, &used);
      if (used == it->second.size()) return value;
    } catch (const std::exception&) {  // std::invalid_argument, std::out_of_range
    }
    throw std::runtime_error(name + ": text chunk '" + key + "' is not a number: " + it->second);
  };
  MogeDepthRange range;
  range.near = number("near", true);
  range.far = number("far", true);
  range.unit = number("unit", false);
  if (!(range.near > 0) || !(range.far > range.near) || !std::isfinite(range.far))
    throw std::runtime_error(name + ": expected 0 < near < far, got " + shortest(range.near) +
                             ", " + shortest(range.far));
  if (!(range.unit > 0) || !std::isfinite(range.unit))
    throw std::runtime_error(name + ": expected a finite unit > 0, got " + shortest(range.unit));
  return range;
}

at::Tensor read_moge_depth(const std::string& path) {
  const MogeDepthRange range = parse_moge_depth_range(io::read_file(path), path);
  MogeDepthCode code;
  code.near = range.near;
  code.far = range.far;
  auto values = io::read_image_values(path);
  if (values.dim() != 2) throw std::runtime_error(path + ": expected a single-channel 16-bit PNG");
  code.values = values.to(at::kInt);
  auto depth = decode_moge_depth(code);
  if (range.unit != 1) depth = depth * static_cast<float>(range.unit);
  return depth;
}

camera::Camera parse_moge_meta(const std::string& text, int64_t width, int64_t height,
                               const std::string& name) {
  const auto fail = [&](const std::string& why) { throw std::runtime_error(name + ": " + why); };
  nlohmann::json meta;
  try {
    meta = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail(std::string("not valid JSON: ") + e.what());
  }
  double fx = 0, fy = 0, cx = 0, cy = 0;
  try {
    const auto& k = meta.at("intrinsics");
    fx = k.at(0).at(0).get<double>() * static_cast<double>(width);
    fy = k.at(1).at(1).get<double>() * static_cast<double>(height);
    cx = k.at(0).at(2).get<double>() * static_cast<double>(width);
    cy = k.at(1).at(2).get<double>() * static_cast<double>(height);
  } catch (const nlohmann::json::exception& e) {
    fail(std::string("needs \"intrinsics\" as a 3x3 array: ") + e.what());
  }
  try {
    return camera::make_camera("PINHOLE", width, height, {fx, fy, cx, cy});
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(name + ": bad intrinsics: " + e.what());
  }
}

std::vector<std::string> list_moge_instances(const std::string& root) {
  std::vector<std::string> out;
  const fs::path base(root);
  if (!fs::is_directory(base)) throw std::runtime_error(root + ": not a folder");
  if (fs::exists(base / ".index.txt")) {
    std::istringstream lines(io::read_file((base / ".index.txt").string()));
    for (std::string line; std::getline(lines, line);) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      if (!line.empty()) out.push_back((base / line).string());
    }
  } else {
    for (const auto& entry : fs::directory_iterator(base))
      if (entry.is_directory() && fs::exists(entry.path() / "depth.png"))
        out.push_back(entry.path().string());
    std::sort(out.begin(), out.end());
  }
  return out;
}

Sample read_moge_instance(const std::string& folder_name, bool metric) {
  const fs::path folder(folder_name);
  const auto fail = [&](const std::string& why) {
    throw std::runtime_error("MoGe instance " + folder_name + ": " + why);
  };
  std::string meta;
  try {
    meta = io::read_file((folder / "meta.json").string());
  } catch (const std::exception& e) {
    fail(std::string("meta.json unreadable: ") + e.what());
  }
  const auto image = io::read_image((folder / "image.jpg").string());
  const auto depth = read_moge_depth((folder / "depth.png").string());
  const int64_t h = image.size(0), w = image.size(1);
  if (depth.size(0) != h || depth.size(1) != w) fail("depth.png and image.jpg sizes differ");
  const camera::Camera cam =
      parse_moge_meta(meta, w, h, "MoGe instance " + folder_name + ": meta.json");
  const auto rays = cam.ray_map(at::kFloat);
  const auto rz = rays.rays.select(-1, 2);
  const auto mask = at::isfinite(depth) & (depth > 0) & rays.valid;
  const auto distance = at::where(mask, depth / rz, at::zeros_like(depth));
  Sample sample{cam, image, distance, mask, metric};
  try {
    validate_sample(sample, "MoGe instance " + folder_name);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  return sample;
}

}  // namespace omnipoint::data
