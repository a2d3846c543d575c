#include "omnipoint/predict/predict_job.h"

#include <ATen/ATen.h>

#include <cmath>
#include <exception>
#include <filesystem>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "omnipoint/camera/camera.h"
#include "omnipoint/camera/camera_info.h"
#include "omnipoint/geometry/points.h"
#include "omnipoint/io/camera_file.h"
#include "omnipoint/io/exif.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/io/point_cloud.h"
#include "omnipoint/predict/colmap_scene.h"
#include "omnipoint/predict/inputs.h"

namespace omnipoint::predict {

namespace {

namespace fs = std::filesystem;

std::string fixed(double value, int digits) {
  std::ostringstream text;
  text.precision(digits);
  text << value;
  return text.str();
}

std::string number(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

// The points of all images in the reconstruction's world frame (fused.ply).
struct FusedCloud {
  std::vector<at::Tensor> points, colors;
  void add(const Prediction& p, const at::Tensor& image, const at::Tensor& camera_from_world) {
    const geometry::PointCloud cloud =
        geometry::valid_points(geometry::make_point_cloud(p.points, image, p.mask));
    points.push_back(world_points(cloud.points, camera_from_world));
    colors.push_back(cloud.colors);
  }
};

// One Run(): the inputs read once for every image, the model, the counts.
class JobRun {
 public:
  JobRun(const PredictJobOptions& options, PredictJobObserver& observer)
      : options_(options), observer_(observer) {}
  PredictJobSummary run();

 private:
  void read_inputs();
  const camera::Camera& given_camera(camera::ImageSize size);
  DecodedImage decode_image(size_t index);
  void predict_image(const ImageEntry& entry, const DecodedImage& decoded);
  SparseDepthInput sparse_depth_file_of(const ImageEntry& entry);
  void warn(const ImageEntry& entry, const std::string& text) {
    ++summary_.warnings;
    observer_.warning(entry, text);
  }
  void write_fused_cloud();
  bool use_exif() const { return options_.use_exif && options_.colmap.empty(); }
  void use_exif_facts(const ImageEntry& entry, const DecodedImage& decoded, PredictOptions& item,
                      std::vector<std::string>& notes);

  const PredictJobOptions& options_;
  PredictJobObserver& observer_;
  ImageList list_;
  SparseDepthFileOptions sparse_files_;
  // Cameras of --camera by image size: only files without a size (UniK3D's JSON) use it.
  std::map<std::pair<int64_t, int64_t>, camera::Camera> cameras_;
  // The first image when it was decoded early (for the camera's size), or why it could not be.
  std::optional<DecodedImage> first_;
  std::exception_ptr first_error_;
  std::optional<ColmapScene> colmap_;
  std::optional<Model> model_;
  FusedCloud fused_;
  PredictJobSummary summary_;
};

const camera::Camera& JobRun::given_camera(camera::ImageSize size) {
  auto known = cameras_.find({size.width, size.height});
  if (known == cameras_.end())
    known = cameras_
                .emplace(std::make_pair(size.width, size.height),
                         io::read_camera(options_.camera, size))
                .first;
  return known->second;
}

void JobRun::read_inputs() {
  list_ = list_images(options_.inputs);
  summary_.images = static_cast<int64_t>(list_.images.size());
  if (list_.images.size() > 1 && !options_.sparse_depth.empty() &&
      !fs::is_directory(options_.sparse_depth))
    throw std::invalid_argument(
        "--sparse-depth " + options_.sparse_depth +
        ": one file for several images; pass a folder with a file per image name");
  sparse_files_.depth_png_units_per_metre = options_.depth_png_units_per_metre;
  sparse_files_.lidar_floats_per_point = options_.lidar_floats_per_point;
  if (!options_.lidar_to_camera.empty())  // once, so a bad file fails before any work
    sparse_files_.camera_from_lidar = io::read_rigid_transform(options_.lidar_to_camera);
  // The camera is read with each image's size, which only files without one (UniK3D's JSON)
  // use; a bad camera fails here, on the first image's size, before any work. That image is
  // kept for its turn (an unreadable one is reported and skipped then).
  if (!options_.camera.empty()) {
    try {
      first_ = read_input_image(list_.images.front().path.string(), options_.max_size, use_exif());
    } catch (const std::exception&) {
      first_error_ = std::current_exception();
    }
    if (first_) given_camera(first_->original_size);
  }
  if (!options_.colmap.empty()) colmap_ = ColmapScene::read(options_.colmap);
}

DecodedImage JobRun::decode_image(size_t index) {
  if (index == 0 && first_error_) std::rethrow_exception(first_error_);
  if (index == 0 && first_) return *std::exchange(first_, std::nullopt);
  return read_input_image(list_.images[index].path.string(), options_.max_size, use_exif());
}

SparseDepthInput JobRun::sparse_depth_file_of(const ImageEntry& entry) {
  const std::optional<fs::path> file =
      fs::is_directory(options_.sparse_depth)
          ? per_image_file(options_.sparse_depth, entry, sparse_depth_extensions())
          : fs::path(options_.sparse_depth);
  if (!file) {
    warn(entry,
         "no sparse depth file for it in " + options_.sparse_depth + " (looked for its name with " +
             std::to_string(sparse_depth_extensions().size()) + " extensions): predicted without");
    return {};
  }
  SparseDepthInput sparse = read_sparse_depth(file->string(), sparse_files_);
  if (options_.sparse_depth_radial) {
    if (!sparse.depth_map.defined())
      throw std::invalid_argument("sparse depth " + file->string() +
                                  ": --sparse-depth-radial applies to depth maps only");
    sparse.depth_is_planar = false;
  }
  if (sparse.lidar_points.defined() && options_.lidar_to_camera.empty())
    warn(entry, "the point cloud " + file->string() +
                    " is taken as in the camera frame (no --lidar-to-camera given)");
  return sparse;
}

// The EXIF orientation (noted) and camera (the image's when none is given) of an image.
void JobRun::use_exif_facts(const ImageEntry& entry, const DecodedImage& decoded,
                            PredictOptions& item, std::vector<std::string>& notes) {
  static const char* const turns[] = {"",
                                      "",
                                      "mirrored left to right",
                                      "turned 180 degrees",
                                      "mirrored top to bottom",
                                      "transposed",
                                      "turned 90 degrees clockwise",
                                      "transposed across the anti-diagonal",
                                      "turned 90 degrees anticlockwise"};
  const io::ExifFacts& exif = decoded.exif;
  if (exif.orientation != 1)
    notes.push_back("EXIF orientation " + std::to_string(exif.orientation) + " applied (" +
                    turns[exif.orientation] + "): the image as photo viewers show it");
  if (item.camera) return;
  std::string rejected;
  const camera::ImageSize size = decoded.original_size;
  if (const auto camera = camera_from_exif(exif, size.width, size.height, &rejected)) {
    item.camera = camera->camera;
    item.camera_source = CameraSource::kExif;
    notes.push_back("camera from EXIF: " + camera->description +
                    ", a pinhole centred in the image (--no-exif: predicted instead)");
  } else if (!rejected.empty()) {
    warn(entry, rejected);
  }
}

void JobRun::predict_image(const ImageEntry& entry, const DecodedImage& decoded) {
  const camera::ImageSize original = decoded.original_size;
  PredictOptions item;
  item.num_tokens = options_.num_tokens;
  item.precision = options_.precision;
  item.fit_model = options_.fit_model;
  item.edge_rtol = options_.edge_rtol;
  if (!options_.camera.empty()) item.camera = given_camera(original);
  if (options_.fov_deg > 0)
    item.camera = camera::centred_pinhole(options_.fov_deg, original.width, original.height);
  const ColmapView* view = nullptr;
  if (colmap_) {
    view = colmap_->find(entry.relative.generic_string());
    if (view == nullptr) {
      warn(entry,
           "not an image of the COLMAP reconstruction: predicted without its camera and sparse "
           "depth, and left out of fused.ply");
    } else {
      item.camera = view->camera;
      item.sparse_depth = sparse_depth_of(*view);
      item.sparse_depth_is_metric = false;
    }
  } else if (!options_.sparse_depth.empty()) {
    item.sparse_depth = sparse_depth_file_of(entry);
  }
  std::vector<std::string> exif_notes;
  if (use_exif()) use_exif_facts(entry, decoded, item, exif_notes);
  item.sparse_depth = resize_sparse_depth(item.sparse_depth, original.width, original.height,
                                          decoded.size.width, decoded.size.height);

  PredictedImage predicted;
  predicted.folder = (fs::path(options_.output_dir) / entry.output).string();
  predicted.original_size = original;
  predicted.size = decoded.size;
  predicted.decode_ms = decoded.decode_ms;
  predicted.prediction = model_->predict(decoded.image, item);
  std::vector<std::string>& notes = predicted.prediction.notes;
  notes.insert(notes.begin(), exif_notes.begin(), exif_notes.end());
  OutputOptions outputs;
  outputs.files = options_.output_files;
  if (view != nullptr) outputs.camera_from_world = view->camera_from_world;
  predicted.writing_ms =
      write_prediction_outputs(predicted.folder, decoded.image, predicted.prediction, outputs);
  ++summary_.written;
  if (view != nullptr) fused_.add(predicted.prediction, decoded.image, view->camera_from_world);
  observer_.image_written(entry, predicted);
  for (const std::string& warning : predicted.prediction.warnings) warn(entry, warning);
}

void JobRun::write_fused_cloud() {
  if (fused_.points.empty()) return;
  const at::Tensor points = at::cat(fused_.points), colors = at::cat(fused_.colors);
  summary_.fused_cloud = (fs::path(options_.output_dir) / "fused.ply").string();
  io::write_ply(summary_.fused_cloud, points, colors);
  summary_.fused_points = points.size(0);
  summary_.fused_images = static_cast<int64_t>(fused_.points.size());
}

PredictJobSummary JobRun::run() {
  if (!io::image_io_available())
    throw std::runtime_error("this build has no image file I/O (OpenCV)");
  options_.Check();
  read_inputs();
  model_ = Model::load(options_.model_path, options_.device);

  observer_.start(list_);
  if (list_.skipped_files > 0)
    observer_.note(std::to_string(list_.skipped_files) +
                   " file(s) in the input folders are not images and were skipped");
  if (colmap_)
    observer_.note(
        "COLMAP's scale is arbitrary: the predictions are aligned to the reconstruction's "
        "points, so they are in its units (not metres) and its world frame");
  for (size_t i = 0; i < list_.images.size(); ++i) {
    const ImageEntry& entry = list_.images[i];
    observer_.image_started(i, entry);
    try {
      predict_image(entry, decode_image(i));
    } catch (const std::exception& e) {
      ++summary_.failed;
      observer_.image_failed(entry, e.what());
    }
    observer_.image_done(i);
  }
  write_fused_cloud();
  observer_.finished(summary_);
  return summary_;
}

}  // namespace

void PredictJobOptions::Check() const {
  const auto fail = [](const std::string& text) { throw std::invalid_argument(text); };
  if (inputs.empty()) fail("no images given");
  if (!camera.empty() && fov_deg > 0) fail("--camera and --fov: give one of them");
  if (!colmap.empty() &&
      (!camera.empty() || fov_deg > 0 || !sparse_depth.empty() || !lidar_to_camera.empty()))
    fail(
        "--colmap brings each image's camera and sparse depth: drop --camera, --fov, "
        "--sparse-depth and --lidar-to-camera");
  if (!(fov_deg >= 0 && fov_deg < 180))
    fail("--fov " + number(fov_deg) + ": expected degrees in (0, 180), or 0 for none");
  if (!(depth_png_units_per_metre > 0) || !std::isfinite(depth_png_units_per_metre))
    fail("--depth-scale " + number(depth_png_units_per_metre) + ": expected a positive number");
  if (lidar_floats_per_point < 3)
    fail("--lidar-format " + std::to_string(lidar_floats_per_point) +
         ": a point has at least 3 float32 values (x y z)");
  if (model_path.empty()) fail("--model: no model given");
  if (max_size < 0) fail("--max-size " + std::to_string(max_size) + ": expected >= 0");
  if (num_tokens < 0) fail("--num-tokens " + std::to_string(num_tokens) + ": expected >= 0");
  if (!(edge_rtol >= 0) || !std::isfinite(edge_rtol))
    fail("--edge-threshold " + number(edge_rtol) + ": expected a number >= 0");
  if (output_dir.empty()) fail("--out: no output folder given");
  const std::set<std::string> known = all_output_files();
  for (const std::string& file : output_files)
    if (known.count(file) == 0) fail("--outputs: unknown file \"" + file + "\"");
}

std::string describe(const ImageEntry& image, const PredictedImage& predicted) {
  const Prediction& p = predicted.prediction;
  std::string text = image.path.string() + " -> " + predicted.folder + " (" +
                     std::to_string(p.mask.sum().item<int64_t>()) + " points";
  if (predicted.size.width != predicted.original_size.width)
    text +=
        " at " + std::to_string(predicted.size.width) + "x" + std::to_string(predicted.size.height);
  text += ", metric scale " + fixed(p.metric_scale, 4);
  if (p.fitted_camera)
    text += std::string(", camera ") + camera_source_name(camera_source_of(p)) + " " +
            p.fitted_camera->model_name() + " hfov " +
            fixed(camera::field_of_view(*p.fitted_camera).horizontal_deg, 4) + " deg";
  if (p.camera_agreement)
    text += ", network rays " + fixed(p.camera_agreement->mean_deg, 3) + "/" +
            fixed(p.camera_agreement->median_deg, 3) + " deg from it (mean/median)";
  if (p.sparse_samples > 0)
    text += ", aligned x" + fixed(p.alignment_factor, 4) + " to " +
            std::to_string(p.sparse_samples) + " sparse samples";
  text += ", decode " + std::to_string(static_cast<int>(predicted.decode_ms)) + " ms, network " +
          std::to_string(static_cast<int>(p.timing.network_ms)) + " ms, writing " +
          std::to_string(static_cast<int>(predicted.writing_ms)) + " ms)";
  return text;
}

PredictJob::PredictJob(PredictJobOptions options, PredictJobObserver* observer)
    : options_(std::move(options)), observer_(observer) {}

PredictJobSummary PredictJob::Run() {
  PredictJobObserver silent;
  return JobRun(options_, observer_ != nullptr ? *observer_ : silent).run();
}

}  // namespace omnipoint::predict
