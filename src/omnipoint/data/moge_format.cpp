#include "omnipoint/data/moge_format.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <optional>
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

at::Tensor read_moge_depth(const std::string& path) {
  const auto text = read_png_text(io::read_file(path), path);
  const auto number = [&](const char* key) {
    const auto it = text.find(key);
    if (it == text.end())
      throw std::runtime_error(path + ": no '" + key + "' text chunk (not a MoGe depth PNG)");
    try {
      return std::stod(it->second);
    } catch (const std::exception&) {
      throw std::runtime_error(path + ": text chunk '" + key + "' is not a number: " + it->second);
    }
  };
  MogeDepthCode code;
  code.near = number("near");
  code.far = number("far");
  if (!(code.near > 0) || !(code.far > code.near) || !std::isfinite(code.far))
    throw std::runtime_error(path + ": expected 0 < near < far, got " + shortest(code.near) + ", " +
                             shortest(code.far));
  auto values = io::read_image_values(path);
  if (values.dim() != 2) throw std::runtime_error(path + ": expected a single-channel 16-bit PNG");
  code.values = values.to(at::kInt);
  auto depth = decode_moge_depth(code);
  if (text.count("unit")) depth = depth * static_cast<float>(number("unit"));
  return depth;
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
  nlohmann::json meta;
  try {
    meta = nlohmann::json::parse(io::read_file((folder / "meta.json").string()));
  } catch (const std::exception& e) {
    fail(std::string("meta.json unreadable: ") + e.what());
  }
  const auto image = io::read_image((folder / "image.jpg").string());
  const auto depth = read_moge_depth((folder / "depth.png").string());
  const int64_t h = image.size(0), w = image.size(1);
  if (depth.size(0) != h || depth.size(1) != w) fail("depth.png and image.jpg sizes differ");
  double fx = 0, fy = 0, cx = 0, cy = 0;
  try {
    const auto& k = meta.at("intrinsics");
    fx = k.at(0).at(0).get<double>() * w;
    fy = k.at(1).at(1).get<double>() * h;
    cx = k.at(0).at(2).get<double>() * w;
    cy = k.at(1).at(2).get<double>() * h;
  } catch (const std::exception& e) {
    fail(std::string("meta.json needs \"intrinsics\" as a 3x3 array: ") + e.what());
  }
  std::optional<camera::Camera> cam;
  try {
    cam = camera::make_camera("PINHOLE", w, h, {fx, fy, cx, cy});
  } catch (const std::exception& e) {
    fail(std::string("bad intrinsics: ") + e.what());
  }
  const auto rays = cam->ray_map(at::kFloat);
  const auto rz = rays.rays.select(-1, 2);
  const auto mask = at::isfinite(depth) & (depth > 0) & rays.valid;
  const auto distance = at::where(mask, depth / rz, at::zeros_like(depth));
  Sample sample{*cam, image, distance, mask, metric};
  try {
    validate_sample(sample, "MoGe instance " + folder_name);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(e.what());
  }
  return sample;
}

}  // namespace omnipoint::data
