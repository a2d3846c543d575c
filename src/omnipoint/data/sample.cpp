#include "omnipoint/data/sample.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <stdexcept>

#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/npy.h"

namespace omnipoint::data {
namespace fs = std::filesystem;

namespace {

std::string first_existing(const fs::path& folder, std::initializer_list<const char*> names) {
  for (const char* name : names)
    if (fs::exists(folder / name)) return (folder / name).string();
  return "";
}

at::Tensor read_hw_npy(const std::string& path, const camera::Camera& camera) {
  auto t = io::read_npy(path);
  if (t.dim() != 2 || t.size(0) != camera.height() || t.size(1) != camera.width())
    throw std::runtime_error(path + ": expected shape (" + std::to_string(camera.height()) + ", " +
                             std::to_string(camera.width()) + ") matching the camera");
  return t;
}

}  // namespace

void validate_sample(const Sample& s, const std::string& what) {
  const int64_t h = s.camera.height(), w = s.camera.width();
  const auto fail = [&](const std::string& why) { throw std::invalid_argument(what + ": " + why); };
  if (!s.image.defined() || s.image.dim() != 3 || s.image.size(0) != h || s.image.size(1) != w ||
      s.image.size(2) != 3 || s.image.scalar_type() != at::kFloat)
    fail("image must be float32 (H, W, 3) matching the camera " + s.camera.to_spec());
  if (!s.distance.defined() || s.distance.dim() != 2 || s.distance.size(0) != h ||
      s.distance.size(1) != w || s.distance.scalar_type() != at::kFloat)
    fail("distance must be float32 (H, W) matching the camera");
  if (!s.mask.defined() || s.mask.sizes() != s.distance.sizes() ||
      s.mask.scalar_type() != at::kBool)
    fail("mask must be bool (H, W)");
  if (!at::isfinite(s.distance).all().item<bool>()) fail("distance has NaN or infinite values");
  if ((s.distance < 0).any().item<bool>()) fail("distance has negative values");
  if ((s.mask & (s.distance <= 0)).any().item<bool>()) fail("mask marks pixels without distance");
  if ((s.mask.logical_not() & (s.distance != 0)).any().item<bool>())
    fail("distance must be 0 outside the mask");
  if (s.labelled != s.mask.any().item<bool>())
    fail(s.labelled ? "no labelled pixel" : "an unlabelled sample has labelled pixels");
}

SampleMeta parse_sample_meta(const std::string& text, const std::string& name) {
  const auto fail = [&](const std::string& why) { throw std::runtime_error(name + ": " + why); };
  nlohmann::json meta;
  try {
    meta = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    fail(std::string("meta.json is not valid JSON: ") + e.what());
  }
  if (!meta.is_object() || !meta.contains("camera")) fail("meta.json has no \"camera\"");
  // meta.value("metric", false) would throw nlohmann's type_error for a non-bool.
  const auto flag = [&](const char* key) {
    const auto found = meta.find(key);
    if (found == meta.end()) return false;
    if (!found->is_boolean())
      fail(std::string("meta.json \"") + key + "\" must be true or false, got " + found->dump());
    return found->get<bool>();
  };
  const bool metric = flag("metric"), sparse_labels = flag("sparse_labels");
  const bool labelled = !meta.contains("labelled") || flag("labelled");
  const auto& spec = meta.at("camera");
  try {
    return {camera::parse_camera(spec.is_string() ? spec.get<std::string>() : spec.dump()), metric,
            sparse_labels, labelled};
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(name + ": unknown or invalid camera: " + e.what());
  }
}

Sample read_sample(const std::string& folder_name) {
  const fs::path folder(folder_name);
  const auto fail = [&](const std::string& why) -> void {
    throw std::runtime_error("sample " + folder_name + ": " + why);
  };
  if (!fs::is_directory(folder)) fail("not a folder");
  std::string meta_text;
  try {
    meta_text = io::read_file((folder / "meta.json").string());
  } catch (const std::exception& e) {
    fail(std::string("meta.json unreadable: ") + e.what());
  }
  const SampleMeta meta = parse_sample_meta(meta_text, "sample " + folder_name);
  const camera::Camera* cam = &meta.camera;
  const int64_t h = cam->height(), w = cam->width();
  const auto image_path = first_existing(folder, {"image.png", "image.jpg", "image.jpeg"});
  if (image_path.empty()) fail("no image.png or image.jpg");
  Sample sample{*cam, {}, {}, {}, meta.metric};
  sample.sparse_labels = meta.sparse_labels;
  sample.labelled = meta.labelled;
  try {
    sample.image = io::read_image(image_path);
    if (sample.image.size(0) != h || sample.image.size(1) != w)
      fail("image is " + std::to_string(sample.image.size(1)) + "x" +
           std::to_string(sample.image.size(0)) + " but the camera is " + cam->to_spec());
    const auto rays = cam->ray_map(at::kFloat);
    at::Tensor distance;
    if (auto path = first_existing(folder, {"distance.npy"}); !path.empty()) {
      distance = read_hw_npy(path, *cam).to(at::kFloat);
    } else if (path = first_existing(folder, {"depth.npy"}); !path.empty()) {
      // Planar depth z = distance * ray.z; near-perpendicular rays carry no usable label.
      const auto depth = read_hw_npy(path, *cam).to(at::kFloat);
      const auto rz = rays.rays.select(-1, 2);
      const auto usable = rz.abs() > 1e-3;
      distance = at::where(usable, depth / at::where(usable, rz, at::ones_like(rz)),
                           at::zeros_like(depth));
    } else {
      fail("no distance.npy or depth.npy");
    }
    if (at::isnan(distance).any().item<bool>()) fail("distance/depth has NaN values");
    distance = at::where(at::isinf(distance) & (distance > 0), at::zeros_like(distance), distance);
    if ((distance < 0).any().item<bool>() || at::isinf(distance).any().item<bool>())
      fail("distance/depth has negative values (or negative depth along a forward ray)");
    at::Tensor mask = distance > 0;
    if (auto path = first_existing(folder, {"mask.png", "mask.npy"}); !path.empty()) {
      at::Tensor stored = path.size() > 4 && path.substr(path.size() - 4) == ".npy"
                              ? read_hw_npy(path, *cam)
                              : io::read_image_values(path);
      if (stored.dim() == 3) stored = stored.select(-1, 0);
      if (stored.size(0) != h || stored.size(1) != w) fail("mask size differs from the camera");
      mask = mask & (stored != 0);
    }
    mask = mask & rays.valid;
    sample.mask = mask;
    sample.distance = at::where(mask, distance, at::zeros_like(distance));
    validate_sample(sample, "sample " + folder_name);
  } catch (const std::runtime_error&) {
    throw;
  } catch (const std::exception& e) {
    fail(e.what());
  }
  return sample;
}

void write_sample(const std::string& folder_name, const Sample& sample,
                  const std::string& extra_meta) {
  validate_sample(sample, "write_sample " + folder_name);
  const fs::path folder(folder_name);
  fs::create_directories(folder);
  nlohmann::json meta = nlohmann::json::object();
  if (!extra_meta.empty()) meta = nlohmann::json::parse(extra_meta);
  meta["format"] = "omnipoint-sample-1";
  meta["camera"] = sample.camera.to_spec();
  meta["metric"] = sample.metric;
  if (sample.sparse_labels) meta["sparse_labels"] = true;
  if (!sample.labelled) meta["labelled"] = false;
  io::write_image_png((folder / "image.png").string(), sample.image.contiguous().cpu());
  io::write_npy((folder / "distance.npy").string(), sample.distance.cpu());
  io::write_image_png((folder / "mask.png").string(), sample.mask.cpu());
  const auto text = meta.dump(2) + "\n";
  io::write_file_atomically((folder / "meta.json").string(),
                            [&](std::ostream& out) { out << text; });
}

}  // namespace omnipoint::data
