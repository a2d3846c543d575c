#pragma once
// The parsers of outside input that are fuzzed (docs/FUZZING.md), one per folder name of
// tests/fuzz/{corpus,malformed,regressions}/<name>/. The libFuzzer targets (fuzz_<name>.cpp)
// and the CTest replay (tests/io/test_parser_corpus.cpp) drive them through these entries, so
// both feed the same bytes to the same calls.
#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

#include "omnipoint/camera/camera.h"
#include "omnipoint/data/dataset.h"
#include "omnipoint/data/formats/kitti_text.h"
#include "omnipoint/data/formats/native.h"
#include "omnipoint/data/formats/native_text.h"
#include "omnipoint/data/moge_format.h"
#include "omnipoint/data/png_text.h"
#include "omnipoint/data/sample.h"
#include "omnipoint/eval/suite.h"
#include "omnipoint/io/colmap.h"
#include "omnipoint/io/hub.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/io/pcd.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/io/point_cloud.h"
#include "omnipoint/io/rig.h"
#include "omnipoint/io/safetensors.h"
#include "omnipoint/io/torch_checkpoint.h"
#include "omnipoint/io/zip_archive.h"
#include "omnipoint/model/config_tables.h"
#include "omnipoint/train/train_config.h"

namespace omnipoint::fuzz {

using ParseFn = void (*)(const std::string& bytes, const std::string& source);

struct Parser {
  const char* name;
  // The checked entry point: returns, or throws an error naming `source` (seeds must parse,
  // malformed files must fail with their message).
  ParseFn parse;
  // More entry points driven with the same bytes; only the contract is checked. May be null.
  ParseFn explore = nullptr;
  // safetensors and npy promise std::runtime_error alone; the others document
  // std::invalid_argument for bad content too.
  bool runtime_error_only = false;
};

// The contract: `call` returns or throws one of the documented error types. Anything else
// propagates (libFuzzer reports an uncaught exception as a crash; the replay test fails).
template <typename Call>
void within_contract(Call call, bool runtime_error_only = false) {
  try {
    call();
  } catch (const std::runtime_error&) {
  } catch (const std::invalid_argument&) {
    if (runtime_error_only) throw;
  }
}

// The CRCs of every complete chunk recomputed, so that mutated chunk contents get past the
// CRC check and reach the text parser.
inline std::string with_png_crcs_fixed(std::string png) {
  std::size_t at = 8;
  while (at + 12 <= png.size()) {
    const auto byte = [&](std::size_t i) { return std::uint32_t(std::uint8_t(png[i])); };
    const std::uint32_t length =
        byte(at) << 24 | byte(at + 1) << 16 | byte(at + 2) << 8 | byte(at + 3);
    if (length > png.size() - at - 12) break;
    const std::uint32_t crc = data::png_crc32(png.substr(at + 4, 4 + length));
    for (int i = 0; i < 4; ++i) png[at + 8 + length + i] = char(crc >> (24 - 8 * i));
    at += 12 + length;
  }
  return png;
}

// One function per parser, so that a fuzz target links only the layers its parser needs.
inline Parser safetensors_parser() {
  return {"safetensors",
          [](const std::string& b, const std::string& s) {
            io::parse_safetensors(b.data(), b.size(), s);
          },
          nullptr, true};
}
// A PyTorch checkpoint as weights (zip, restricted unpickler, tensors, layout). Bytes that are
// not a zip go to the unpickler alone, as a data.pkl whose storages are served zero-filled
// (up to 4096 bytes), so mutations of the pickle reach it without the zip around it.
inline void parse_checkpoint(const std::string& b, const std::string& s) {
  if (io::looks_like_zip(b.data(), b.size()) || io::looks_like_legacy_torch(b.data(), b.size())) {
    io::checkpoint_weights(io::parse_torch_checkpoint(b.data(), b.size(), s), s);
    return;
  }
  const io::StorageLoader zeros = [&](const io::StorageRequest& request) {
    if (request.numel > 4096 / static_cast<std::int64_t>(c10::elementSize(request.dtype)))
      throw std::runtime_error(s + ": storage '" + request.key + "' is too large to serve");
    return at::zeros({request.numel}, at::TensorOptions().dtype(request.dtype));
  };
  io::checkpoint_weights(io::unpickle(b.data(), b.size(), zeros, s), s);
}
inline Parser checkpoint_parser() {
  return {"checkpoint", parse_checkpoint, nullptr, true};
}
inline Parser npy_parser() {
  return {"npy",
          [](const std::string& b, const std::string& s) { io::parse_npy(b.data(), b.size(), s); },
          nullptr, true};
}
inline Parser ply_parser() {
  return {"ply", [](const std::string& b, const std::string& s) { io::parse_ply(b, s); }};
}
// A .bin scan as KITTI's 4 floats per point; also as nuScenes' 5 and as 3, and the same bytes
// as a --lidar-format value.
inline Parser lidar_bin_parser() {
  return {"lidar_bin",
          [](const std::string& b, const std::string& s) { io::parse_lidar_bin(b, s, 4); },
          [](const std::string& b, const std::string& s) {
            within_contract([&] { io::parse_lidar_bin(b, s, 5); });
            within_contract([&] { io::parse_lidar_bin(b, s, 3); });
            within_contract([&] { io::lidar_floats_per_point(b); });
          }};
}
inline Parser pcd_parser() {
  return {"pcd", [](const std::string& b, const std::string& s) { io::parse_pcd(b, s); }};
}
// COLMAP's cameras, images and points3D files, text and binary. The checked entry picks the
// parser by the file's name (cameras*.txt, images*.bin, points3D*.txt, ...) and refuses other
// names, the fuzzer's too; all six parsers are driven with the same bytes.
inline void parse_colmap_file(const std::string& b, const std::string& s) {
  const std::filesystem::path path(s);
  const std::string file = path.filename().string(), extension = path.extension().string();
  const auto named = [&](const char* stem, const char* ext) {
    return file.rfind(stem, 0) == 0 && extension == ext;
  };
  if (named("cameras", ".txt"))
    io::parse_colmap_cameras_text(b, s);
  else if (named("cameras", ".bin"))
    io::parse_colmap_cameras_binary(b, s);
  else if (named("images", ".txt"))
    io::parse_colmap_images_text(b, s);
  else if (named("images", ".bin"))
    io::parse_colmap_images_binary(b, s);
  else if (named("points3D", ".txt"))
    io::parse_colmap_points_text(b, s);
  else if (named("points3D", ".bin"))
    io::parse_colmap_points_binary(b, s);
  else
    throw std::invalid_argument(s +
                                ": not a COLMAP file name (cameras, images or points3D; "
                                ".txt or .bin)");
}
inline Parser colmap_parser() {
  return {"colmap", parse_colmap_file, [](const std::string& b, const std::string& s) {
            within_contract([&] { io::parse_colmap_cameras_text(b, s); });
            within_contract([&] { io::parse_colmap_cameras_binary(b, s); });
            within_contract([&] { io::parse_colmap_images_text(b, s); });
            within_contract([&] { io::parse_colmap_images_binary(b, s); });
            within_contract([&] { io::parse_colmap_points_text(b, s); });
            within_contract([&] { io::parse_colmap_points_binary(b, s); });
          }};
}
// The text files of KITTI raw and KITTI-360 (data/formats/kitti_text.h). The checked entry
// picks the parser by the file's name, as colmap's does: *.yaml a fisheye calibration,
// calib_cam_to_cam* (camera image_02), perspective* (image_00), calib_cam_to_pose*, poses*,
// kitti360_list* a DAC list, any other name a KITTI raw split list; all are driven with the
// same bytes.
inline void parse_kitti_text_file(const std::string& b, const std::string& s) {
  const std::filesystem::path path(s);
  const std::string file = path.filename().string();
  const auto named = [&](const char* stem) { return file.rfind(stem, 0) == 0; };
  if (path.extension() == ".yaml")
    data::parse_kitti360_fisheye(b, s, data::PrincipalPoint::kIntegerCentre, false);
  else if (named("calib_cam_to_cam"))
    data::parse_kitti_raw_camera(b, s, "image_02", data::PrincipalPoint::kIntegerCentre);
  else if (named("perspective"))
    data::parse_kitti360_perspective(b, s, "image_00", data::PrincipalPoint::kIntegerCentre);
  else if (named("calib_cam_to_pose"))
    data::parse_kitti360_cam_to_pose(b, s);
  else if (named("poses"))
    data::parse_kitti360_poses(b, s);
  else if (named("kitti360_list"))
    data::parse_kitti360_list(b, s);
  else
    data::parse_kitti_raw_list(b, s);
}
inline Parser kitti_text_parser() {
  return {
      "kitti_text", parse_kitti_text_file, [](const std::string& b, const std::string& s) {
        using data::PrincipalPoint;
        within_contract([&] { data::parse_kitti360_fisheye(b, s, PrincipalPoint::kCorner, true); });
        within_contract([&] { data::parse_kitti_raw_camera(b, s, "image_03", {}); });
        within_contract([&] { data::parse_kitti360_perspective(b, s, "image_01", {}); });
        within_contract([&] { data::parse_kitti360_cam_to_pose(b, s); });
        within_contract([&] { data::parse_kitti360_poses(b, s); });
        within_contract([&] { data::parse_kitti360_list(b, s); });
        within_contract([&] { data::parse_kitti_raw_list(b, s); });
      }};
}
inline Parser rigid_transform_parser() {
  return {"rigid_transform",
          [](const std::string& b, const std::string& s) { io::parse_rigid_transform(b, s); }};
}
// A rig file (io/rig.h); camera file paths resolve against the working folder.
inline Parser rig_parser() {
  return {"rig", [](const std::string& b, const std::string& s) { io::parse_rig(b, s, ""); }};
}
// A camera file (cameras.txt or JSON); the same bytes as a --camera spec string, as a file with
// a camera id and as a file read with an image size.
inline Parser camera_parser() {
  return {
      "camera", [](const std::string& b, const std::string& s) { camera::parse_camera_file(b, s); },
      [](const std::string& b, const std::string& s) {
        within_contract([&] { camera::parse_camera(b); });
        within_contract([&] { camera::is_camera_line(b); });
        within_contract([&] { camera::parse_camera_file(b, s, "1"); });
        // With the image's size, as predict reads size-less files (UniK3D's JSON).
        within_contract([&] { camera::parse_camera_file(b, s, "", camera::ImageSize{64, 48}); });
      }};
}
// A rig log's manifest.jsonl (the "rig-log" format, data/formats/rig_log.cpp), opened as a
// dataset: the bytes become the manifest of a scratch root holding the files a line may name
// (image.png, lidar.bin, a transform calib.txt, a camera file cameras.txt), so its lines' paths,
// cameras, transforms and LiDAR formats are read as a real root's are. The reader names the
// manifest by its scratch path; the error carries it as `source`.
class RigLogScratch {
 public:
  RigLogScratch() {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "omnipoint_fuzz_rig_log_XXXXXX").string();
    if (mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("no scratch folder");
    root_ = pattern;
    const auto write = [&](const char* name, const std::string& text) {
      std::ofstream(root_ / name, std::ios::binary) << text;
    };
    write("image.png", "");
    write("lidar.bin", "");
    write("calib.txt", "0 -1 0 0\n0 0 -1 -0.08\n1 0 0 -0.27\n");
    write("cameras.txt", "# CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]\n1 PINHOLE 64 48 50 50 32 24\n");
  }
  ~RigLogScratch() {
    std::error_code ignored;
    std::filesystem::remove_all(root_, ignored);
  }
  RigLogScratch(const RigLogScratch&) = delete;
  RigLogScratch& operator=(const RigLogScratch&) = delete;
  const std::filesystem::path& root() const { return root_; }

 private:
  std::filesystem::path root_;
};
// `text` with every `name` in it replaced by `by`.
inline std::string renamed(std::string text, const std::string& name, const std::string& by) {
  for (auto at = text.find(name); at != std::string::npos; at = text.find(name, at + by.size()))
    text.replace(at, name.size(), by);
  return text;
}
inline void parse_rig_log_manifest(const std::string& b, const std::string& s) {
  static const RigLogScratch scratch;
  const std::string manifest = (scratch.root() / "manifest.jsonl").string();
  std::ofstream(manifest, std::ios::binary | std::ios::trunc) << b;
  try {
    data::open_dataset("rig-log", {scratch.root().string(), false, manifest});
  } catch (const std::invalid_argument& error) {
    throw std::invalid_argument(renamed(error.what(), manifest, s));
  } catch (const std::runtime_error& error) {
    throw std::runtime_error(renamed(error.what(), manifest, s));
  }
}
inline Parser rig_log_parser() {
  return {"rig_log", parse_rig_log_manifest};
}
// A benchmark suite file (`omnipoint eval --suite`), its split lists relative to no folder.
inline Parser eval_suite_parser() {
  return {"eval_suite",
          [](const std::string& b, const std::string& s) { eval::parse_suite(b, s, ""); }};
}
inline Parser train_config_parser() {
  return {"train_config",
          [](const std::string& b, const std::string& s) { train::TrainConfig::from_text(b, s); }};
}
// A checkpoint's model config, the "config" entry of its safetensors metadata, read as
// infer::load_network reads it: by OmniPoint's reader (model::config_from_metadata), or by
// MoGe-2's (model::MoGe2Config::from_json_text) for files named moge2* (the fuzzer's input has
// no name: OmniPoint's); errors get "model SOURCE: " in front, as load_network's do.
inline void parse_checkpoint_metadata(const std::string& b, const std::string& s) {
  try {
    if (std::filesystem::path(s).filename().string().rfind("moge2", 0) == 0)
      model::MoGe2Config::from_json_text(b);
    else
      model::config_from_metadata({{"format", "omnipoint"}, {"config", b}});
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("model " + s + ": " + e.what());
  }
}
// What reads is written, and what is written reads back to the same text: a config the writer
// makes and the reader refuses (or reads otherwise) is a finding (std::logic_error).
template <typename Read, typename Write>
void expect_read_back(const std::string& text, Read read, Write write) {
  std::optional<decltype(read(text))> config;
  try {
    config = read(text);
  } catch (const std::invalid_argument&) {
    return;
  }
  const std::string written = write(*config);
  try {
    if (write(read(written)) == written) return;
  } catch (const std::invalid_argument& e) {
    throw std::logic_error("a written config does not read back: " + std::string(e.what()));
  }
  throw std::logic_error("a written config reads back otherwise: " + written);
}
inline Parser checkpoint_metadata_parser() {
  return {"checkpoint_metadata", parse_checkpoint_metadata,
          [](const std::string& b, const std::string&) {
            expect_read_back(
                b, [](const std::string& t) { return model::OmniPointConfig::from_json_text(t); },
                [](const model::OmniPointConfig& c) { return c.to_json_text(); });
            expect_read_back(
                b, [](const std::string& t) { return model::MoGe2Config::from_json_text(t); },
                [](const model::MoGe2Config& c) {
                  nlohmann::json json;
                  model::moge2_table().write(c, json);
                  return json.dump();
                });
            // The whole "__metadata__" object (string values), as io::parse_safetensors
            // hands it over.
            const nlohmann::json metadata = nlohmann::json::parse(b, nullptr, false);
            if (!metadata.is_object()) return;
            std::map<std::string, std::string> entries;
            for (const auto& [key, value] : metadata.items())
              if (value.is_string()) entries[key] = value.get<std::string>();
            within_contract([&] { model::config_from_metadata(entries); });
          }};
}
// A MoGe depth PNG's text chunks (near, far, unit), as read; then with valid CRCs.
inline Parser png_text_parser() {
  return {"png_text",
          [](const std::string& b, const std::string& s) { data::parse_moge_depth_range(b, s); },
          [](const std::string& b, const std::string& s) {
            const std::string fixed = with_png_crcs_fixed(b);
            within_contract([&] { data::read_png_text(fixed, s); });
            within_contract([&] { data::parse_moge_depth_range(fixed, s); });
          }};
}
// A MoGe instance's meta.json, for a 64x48 image.
inline Parser moge_meta_parser() {
  return {"moge_meta",
          [](const std::string& b, const std::string& s) { data::parse_moge_meta(b, 64, 48, s); }};
}
inline Parser sample_meta_parser() {
  return {"sample_meta",
          [](const std::string& b, const std::string& s) { data::parse_sample_meta(b, s); }};
}
// The hub's model API answer (GET /api/models/OWNER/REPO): its checkpoint file names, which
// become cache paths.
inline Parser hub_model_info_parser() {
  return {"hub_model_info",
          [](const std::string& b, const std::string& s) { io::hub::checkpoint_files(b, s); }};
}

// The text files of datasets' native layouts (data/formats/): Structured3D's camera_pose.txt
// for files named camera_pose*, Virtual KITTI 2's intrinsic.txt for intrinsic*, Hypersim's
// CSVs for metadata_camera_parameters* and metadata_images_split*, ARKitScenes' .pincam for
// *.pincam, else a split list; all the
// parsers are driven with the same bytes.
inline void parse_native_text(const std::string& b, const std::string& s) {
  const std::string name = std::filesystem::path(s).filename().string();
  const auto starts = [&](const char* prefix) { return name.rfind(prefix, 0) == 0; };
  if (starts("camera_pose"))
    data::formats::parse_structured3d_pose(b, s);
  else if (starts("intrinsic"))
    data::formats::parse_vkitti2_intrinsics(b, s);
  else if (starts("metadata_camera_parameters"))
    data::formats::parse_hypersim_cameras(b, s);
  else if (starts("metadata_images_split"))
    data::formats::parse_hypersim_split(b, s);
  else if (std::filesystem::path(s).extension() == ".pincam")
    data::formats::parse_pincam(b, s);
  else
    data::formats::parse_split_list(b, s);
}
inline Parser native_text_parser() {
  return {"native_text", parse_native_text, [](const std::string& b, const std::string& s) {
            within_contract([&] { data::formats::parse_structured3d_pose(b, s); });
            within_contract([&] { data::formats::parse_pincam(b, s); });
            within_contract([&] { data::formats::parse_split_list(b, s); });
            within_contract([&] { data::formats::parse_vkitti2_intrinsics(b, s); });
            within_contract([&] { data::formats::parse_hypersim_cameras(b, s); });
            within_contract([&] { data::formats::parse_hypersim_split(b, s); });
          }};
}

// All of them (the replay test).
inline const std::vector<Parser>& parsers() {
  static const std::vector<Parser> table = {safetensors_parser(),
                                            checkpoint_parser(),
                                            npy_parser(),
                                            ply_parser(),
                                            lidar_bin_parser(),
                                            pcd_parser(),
                                            colmap_parser(),
                                            rigid_transform_parser(),
                                            rig_parser(),
                                            camera_parser(),
                                            train_config_parser(),
                                            png_text_parser(),
                                            moge_meta_parser(),
                                            sample_meta_parser(),
                                            checkpoint_metadata_parser(),
                                            hub_model_info_parser(),
                                            native_text_parser(),
                                            kitti_text_parser(),
                                            eval_suite_parser(),
                                            rig_log_parser()};
  return table;
}

inline const Parser& parser_named(const std::string& name) {
  for (const Parser& parser : parsers())
    if (name == parser.name) return parser;
  throw std::invalid_argument("no fuzzed parser named '" + name + "'");
}

// Everything the fuzzer runs for one input.
inline void run_all(const Parser& parser, const std::string& bytes, const std::string& source) {
  within_contract([&] { parser.parse(bytes, source); }, parser.runtime_error_only);
  if (parser.explore) parser.explore(bytes, source);
}

// The body of LLVMFuzzerTestOneInput.
inline int fuzz_one(const Parser& parser, const std::uint8_t* data, std::size_t size) {
  run_all(parser, std::string(reinterpret_cast<const char*>(data), size), "fuzz");
  return 0;
}

}  // namespace omnipoint::fuzz
