#include "omnipoint/predict/rig_predict_job.h"

#include <ATen/ATen.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <future>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <utility>

#include "omnipoint/geometry/points.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/glb.h"
#include "omnipoint/io/image.h"
#include "omnipoint/io/ply.h"
#include "omnipoint/io/point_cloud.h"
#include "omnipoint/io/staged_folder.h"
#include "omnipoint/predict/colmap_scene.h"
#include "omnipoint/predict/inputs.h"
#include "omnipoint/predict/median.h"
#include "omnipoint/predict/rig_overlap.h"
#include "omnipoint/predict/sequence_record.h"

namespace omnipoint::predict {

namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string number(double value, int digits = 6) {
  std::ostringstream text;
  text.precision(digits);
  text << value;
  return text.str();
}

// The frame folders: the immediate subfolders of `dir` in name order (hidden and staging
// folders left out).
std::vector<std::string> list_frames(const std::string& dir) {
  if (!fs::is_directory(dir))
    throw std::invalid_argument("--rig: the frames folder " + dir + " is not a folder");
  std::vector<std::string> frames;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory() && name.front() != '.') frames.push_back(name);
  }
  if (frames.empty())
    throw std::invalid_argument("--rig: " + dir +
                                " holds no frame folder (FRAMES/<frame>/<camera>.jpg ...)");
  std::sort(frames.begin(), frames.end());
  return frames;
}

// What one frame folder holds: each camera's image, the sweep, and files that are neither.
struct FrameFiles {
  std::map<std::string, fs::path> images;  // by camera name
  std::optional<fs::path> lidar;
  std::vector<fs::path> others;
};

FrameFiles frame_files(const fs::path& folder, const io::Rig& rig) {
  std::vector<fs::path> paths;
  for (const fs::directory_entry& entry : fs::directory_iterator(folder))
    if (entry.is_regular_file()) paths.push_back(entry.path());
  std::sort(paths.begin(), paths.end());
  FrameFiles files;
  for (const fs::path& path : paths) {
    const std::string stem = path.stem().string();
    if (stem == "lidar" && io::is_point_cloud_file(path.string())) {
      if (files.lidar)
        throw std::invalid_argument(folder.string() + ": two LiDAR sweeps (" +
                                    files.lidar->filename().string() + ", " +
                                    path.filename().string() + ")");
      files.lidar = path;
    } else if (rig.find(stem) != nullptr && io::has_image_extension(path.string())) {
      const auto [known, added] = files.images.emplace(stem, path);
      if (!added)
        throw std::invalid_argument(folder.string() + ": two images of camera " + stem + " (" +
                                    known->second.filename().string() + ", " +
                                    path.filename().string() + ")");
    } else {
      files.others.push_back(path);
    }
  }
  return files;
}

// camera_from_body of a body_from_camera pose: [Rᵀ | −Rᵀt], exact (no general inverse).
at::Tensor inverse_pose(const at::Tensor& body_from_camera) {
  const at::Tensor rotation = body_from_camera.slice(0, 0, 3).slice(1, 0, 3);
  const at::Tensor translation = body_from_camera.slice(0, 0, 3).select(1, 3);
  at::Tensor inverse = at::eye(4, at::kDouble);
  inverse.slice(0, 0, 3).slice(1, 0, 3).copy_(rotation.t());
  inverse.slice(0, 0, 3).select(1, 3).copy_(-rotation.t().matmul(translation));
  return inverse;
}

// A pose's 3 rows of 4 numbers, as the rig file writes them.
json pose_rows(const at::Tensor& pose) {
  const at::Tensor m = pose.to(at::kDouble).contiguous();
  json rows = json::array();
  for (int64_t r = 0; r < 3; ++r)
    rows.push_back(
        std::vector<double>(m.data_ptr<double>() + 4 * r, m.data_ptr<double>() + 4 * r + 4));
  return rows;
}

// One decoded camera image of a frame.
struct CameraImage {
  const io::RigCamera* camera;
  fs::path path;
  at::Tensor image;  // (H, W, 3) float32 at the network's size
};

// One frame folder read and decoded (ahead of the network, on another thread): what
// predict_frame needs, the warnings in the order they were found, and the error that stopped
// the reading (after those warnings).
struct FrameInput {
  RigFrameResult frame;  // its name, folder, missing cameras and sweep file
  std::vector<CameraImage> images;
  at::Tensor sweep;  // (N, 3) in the LiDAR's frame; undefined when none
  std::vector<std::string> warnings;
  std::exception_ptr error;
};

// What an earlier sequence run recorded of a finished frame (its rig.json's sequence record).
struct FinishedFrame {
  double rig_scale = 0;        // applied
  double frame_rig_scale = 0;  // the frame's own, what the running estimate was fed
};

// The finished frame's record in `folder`, or nullopt when the folder is not a finished frame
// of a rig sequence (read_sequence_record).
std::optional<FinishedFrame> finished_frame(const fs::path& folder, ScaleMode mode) {
  const std::optional<json> record = read_sequence_record(folder / "rig.json", mode);
  if (!record) return std::nullopt;
  try {
    return FinishedFrame{record->at("rig_scale").get<double>(),
                         record->at("frame_rig_scale").get<double>()};
  } catch (const std::exception&) {
    return std::nullopt;
  }
}

// One Run(): the rig, the frames, the predictor, the counts.
class JobRun {
 public:
  JobRun(const RigPredictJobOptions& options, RigPredictJobObserver& observer)
      : options_(options), observer_(observer) {}
  RigPredictJobSummary run();

 private:
  void read_frame(const std::string& name, FrameInput& input) const;
  RigFrameResult predict_frame(FrameInput input);
  SequenceScale advanced_scale(double own, double& applied) const;
  void follow_sequence(RigFrameResult& frame);
  std::vector<OverlapCamera> overlap_cameras(const RigFrameResult& frame) const;
  void set_scales(RigFrameResult& frame) const;
  void write_frame(RigFrameResult& frame, const std::vector<CameraImage>& images) const;
  std::string rig_json(const RigFrameResult& frame) const;
  void warn(const std::string& frame, const std::string& text) {
    ++summary_.warnings;
    observer_.warning(frame, text);
  }

  const RigPredictJobOptions& options_;
  RigPredictJobObserver& observer_;
  io::Rig rig_;
  int64_t lidar_floats_per_point_ = 4;
  RigCameraPredictor predictor_;
  RigPredictJobSummary summary_;
  // With sequence: the frames, the one being predicted, the running rig scale (the frames
  // written or resumed so far) and what it becomes once the frame being predicted is written.
  size_t frame_count_ = 0;
  size_t frame_index_ = 0;
  std::optional<SequenceScale> sequence_scale_;
  std::optional<SequenceScale> sequence_scale_after_;
};

// Reads frame `name` into `input` (a throw leaves the warnings found before it there).
void JobRun::read_frame(const std::string& name, FrameInput& input) const {
  RigFrameResult& frame = input.frame;
  frame.name = name;
  frame.folder = (fs::path(options_.output_dir) / name).string();
  const fs::path folder = fs::path(options_.frames_dir) / name;
  const FrameFiles files = frame_files(folder, rig_);
  for (const fs::path& other : files.others)
    input.warnings.push_back(other.string() +
                             ": neither an image of a rig camera nor lidar.<bin|ply|pcd>: "
                             "ignored");
  std::vector<CameraImage>& images = input.images;
  for (const io::RigCamera& camera : rig_.cameras) {
    const auto file = files.images.find(camera.name);
    if (file == files.images.end()) {
      frame.missing_cameras.push_back(camera.name);
      continue;
    }
    const at::Tensor original = io::read_image(file->second.string());
    const camera::ImageSize size =
        size_within(original.size(1), original.size(0), options_.max_size);
    images.push_back({&camera, file->second, resize_image(original, size.width, size.height)});
  }
  if (images.empty())
    throw std::invalid_argument(folder.string() + ": no image of the rig's cameras (" +
                                rig_.cameras.front().name + ".jpg, ...)");
  for (const std::string& missing : frame.missing_cameras)
    input.warnings.push_back("camera " + missing + " has no image in " + folder.string() +
                             ": the frame is predicted without it");

  const std::optional<fs::path> lidar = options_.lidar ? files.lidar : std::nullopt;
  if (lidar && !rig_.lidar) {
    input.warnings.push_back(lidar->string() +
                             ": the rig file has no lidar (body_from_lidar): the sweep is not "
                             "used");
  } else if (lidar) {
    input.sweep = io::read_point_cloud(lidar->string(), lidar_floats_per_point_, "LiDAR sweep");
    frame.lidar = lidar->string();
  }
}

RigFrameResult JobRun::predict_frame(FrameInput input) {
  RigFrameResult& frame = input.frame;
  const std::string& name = frame.name;
  for (const std::string& warning : input.warnings) warn(name, warning);
  if (input.error) std::rethrow_exception(input.error);
  const std::vector<CameraImage>& images = input.images;
  const at::Tensor& sweep = input.sweep;

  for (const CameraImage& image : images) {
    PredictOptions item;
    item.camera = image.camera->camera;
    item.camera_source = CameraSource::kGiven;
    item.num_tokens = options_.num_tokens;
    item.precision = options_.precision;
    item.edge_rtol = options_.edge_rtol;
    if (sweep.defined()) {
      item.sparse_depth.lidar_points = sweep;
      item.sparse_depth.camera_from_lidar =
          inverse_pose(image.camera->body_from_camera).matmul(rig_.lidar->body_from_lidar);
      item.sparse_depth.placement_advice =
          "the rig places the sweep: check the rig file's lidar.body_from_lidar and this "
          "camera's body_from_camera, each the sensor-to-body transform";
    }
    RigCameraResult result;
    result.name = image.camera->name;
    result.image = image.path.string();
    result.prediction = predictor_({name, image.camera->name, image.image}, item);
    for (const std::string& warning : result.prediction.warnings)
      warn(name, "camera " + result.name + ": " + warning);
    frame.cameras.push_back(std::move(result));
  }
  set_scales(frame);
  follow_sequence(frame);
  write_frame(frame, images);
  return frame;
}

// The running rig scale after a frame whose own rig scale is `own` (--scale fixed: the first
// frame's); `applied` gets the frame's applied rig scale.
SequenceScale JobRun::advanced_scale(double own, double& applied) const {
  SequenceScale state = sequence_scale_ ? *sequence_scale_ : SequenceScale(options_.scale, own);
  applied = state.next(own);
  return state;
}

// With sequence: the rig scale follows the running estimate unless it was measured (see the
// header); the cameras keep their factors relative to it.
void JobRun::follow_sequence(RigFrameResult& frame) {
  frame.frame_rig_scale = frame.rig_scale;
  if (!options_.sequence) return;
  const double own = frame.rig_scale;
  double applied = own;
  sequence_scale_after_ = advanced_scale(own, applied);
  const bool measured =
      std::any_of(frame.cameras.begin(), frame.cameras.end(),
                  [](const RigCameraResult& camera) { return camera.scale_source == "lidar"; });
  if (measured || applied == own) return;
  const double factor = applied / own;
  frame.rig_scale = applied;
  for (RigCameraResult& camera : frame.cameras) {
    camera.scale *= factor;
    camera.applied_scale *= factor;
    apply_metric_scale(camera.prediction, camera.prediction.metric_scale * factor);
    camera.prediction.notes.push_back("the rig scale follows the sequence (--scale " +
                                      std::string(scale_mode_name(options_.scale)) + "): " +
                                      number(applied) + " (the frame's own " + number(own) + ")");
  }
}

// The overlap rule's view of the frame's predictions, at their current scales.
std::vector<OverlapCamera> JobRun::overlap_cameras(const RigFrameResult& frame) const {
  std::vector<OverlapCamera> cameras;
  for (const RigCameraResult& camera : frame.cameras) {
    const Prediction& p = camera.prediction;
    const io::RigCamera& rig_camera = *rig_.find(camera.name);
    const int64_t height = p.distance.size(0), width = p.distance.size(1);
    cameras.push_back({rig_camera.camera.width() == width && rig_camera.camera.height() == height
                           ? rig_camera.camera
                           : rig_camera.camera.resized(width, height),
                       rig_camera.body_from_camera, p.rays, p.distance, p.mask, camera.scale,
                       camera.scale_source == "lidar"});
  }
  return cameras;
}

void JobRun::set_scales(RigFrameResult& frame) const {
  std::vector<double> lidar_scales;
  for (RigCameraResult& camera : frame.cameras) {
    camera.scale = camera.prediction.metric_scale;
    const bool aligned = !frame.lidar.empty() && camera.prediction.sparse_samples > 0;
    camera.scale_source = aligned ? "lidar" : "network";
    if (aligned) lidar_scales.push_back(camera.scale);
  }
  const bool by_lidar = !lidar_scales.empty();
  if (options_.overlap) {
    OverlapOptions overlap;
    if (by_lidar) overlap.free_group_scale = median(lidar_scales);
    const OverlapResult result = reconcile_overlap_scales(overlap_cameras(frame), overlap);
    for (size_t c = 0; c < frame.cameras.size(); ++c) {
      if (!result.reconciled[c]) continue;
      frame.cameras[c].scale *= result.factors[c];
      frame.cameras[c].scale_source = "overlap";
    }
    frame.overlap_residual = result.residual;
    frame.overlaps = result.pairs;
  }
  std::vector<double> all_scales;
  for (const RigCameraResult& camera : frame.cameras) all_scales.push_back(camera.scale);
  frame.rig_scale = median(by_lidar ? lidar_scales : all_scales);
  for (RigCameraResult& camera : frame.cameras) {
    camera.disagreement = camera.scale / frame.rig_scale - 1.0;
    camera.applied_scale = camera.scale_source == "network" ? frame.rig_scale : camera.scale;
    const double own = camera.prediction.metric_scale;
    if (camera.applied_scale == own) continue;
    apply_metric_scale(camera.prediction, camera.applied_scale);
    camera.prediction.notes.push_back(
        camera.scale_source == "overlap"
            ? "reconciled with the cameras it overlaps: scale " + number(camera.applied_scale) +
                  " (the network's " + number(own) + ")"
            : "brought to the rig scale " + number(frame.rig_scale) + " (its own " + number(own) +
                  "; the median of the " +
                  (by_lidar ? "LiDAR-aligned cameras' scales" : "cameras' scales") + ")");
  }
  if (!options_.overlap) {  // the disagreement the median rule leaves over the overlaps
    const OverlapResult left = measure_overlaps(overlap_cameras(frame));
    frame.overlap_residual = left.residual;
    frame.overlaps = left.pairs;
  }
}

std::string JobRun::rig_json(const RigFrameResult& frame) const {
  json cameras = json::object();
  for (const RigCameraResult& camera : frame.cameras)
    cameras[camera.name] = {
        {"scale", camera.scale},
        {"scale_source", camera.scale_source},
        {"disagreement", camera.disagreement},
        {"applied_scale", camera.applied_scale},
        {"sparse_samples", camera.prediction.sparse_samples},
        {"image", camera.image},
        {"body_from_camera", pose_rows(rig_.find(camera.name)->body_from_camera)}};
  const auto any_source = [&](const char* source) {
    return std::any_of(
        frame.cameras.begin(), frame.cameras.end(),
        [&](const RigCameraResult& camera) { return camera.scale_source == source; });
  };
  std::string rule = any_source("lidar") ? "median of the LiDAR-aligned cameras' scales"
                                         : "median of the cameras' scales";
  if (any_source("overlap")) rule += ", the others reconciled where their views overlap";
  if (options_.sequence && !any_source("lidar"))
    rule += "; the rig scale follows the sequence (--scale " +
            std::string(scale_mode_name(options_.scale)) + ")";
  json overlaps = json::array();
  for (const OverlapPair& pair : frame.overlaps)
    overlaps.push_back({{"camera", frame.cameras[pair.i].name},
                        {"sees", frame.cameras[pair.j].name},
                        {"pixels", pair.pixels},
                        {"inliers", pair.inliers},
                        {"log_ratio", pair.log_ratio},
                        {"residual", pair.residual},
                        {"spread", pair.spread},
                        {"sigma", pair.sigma},
                        {"weight", pair.weight}});
  json report = {
      {"frame", rig_.frame},
      {"rig_scale", frame.rig_scale},
      {"overlap_residual", frame.overlap_residual ? json(*frame.overlap_residual) : json(nullptr)},
      {"scale_rule", rule},
      {"lidar", frame.lidar.empty() ? json(nullptr) : json(frame.lidar)},
      {"missing_cameras", frame.missing_cameras},
      {"fused_points", frame.fused_points},
      {"cameras", cameras},
      {"overlaps", overlaps}};
  if (options_.sequence)
    report["sequence"] = {{"frame_index", frame_index_},
                          {"frames", frame_count_},
                          {"scale_mode", scale_mode_name(options_.scale)},
                          {"rig_scale", frame.rig_scale},
                          {"frame_rig_scale", frame.frame_rig_scale}};
  return report.dump(2) + "\n";
}

void JobRun::write_frame(RigFrameResult& frame, const std::vector<CameraImage>& images) const {
  io::StagedFolder staged(frame.folder);
  std::vector<at::Tensor> points, colors;
  for (size_t i = 0; i < frame.cameras.size(); ++i) {
    const RigCameraResult& camera = frame.cameras[i];
    OutputOptions outputs;
    outputs.files = options_.output_files;
    outputs.camera_from_world = inverse_pose(images[i].camera->body_from_camera);
    write_prediction_outputs((staged.path() / camera.name).string(), images[i].image,
                             camera.prediction, outputs);
    const geometry::PointCloud cloud = geometry::valid_points(geometry::make_point_cloud(
        camera.prediction.points, images[i].image, camera.prediction.mask));
    points.push_back(world_points(cloud.points, outputs.camera_from_world));
    colors.push_back(cloud.colors);
  }
  const at::Tensor fused = at::cat(points), fused_colors = at::cat(colors);
  io::write_ply((staged.path() / "fused.ply").string(), fused, fused_colors);
  if (options_.output_files.count("points.glb") != 0)
    io::write_glb_points((staged.path() / "fused.glb").string(), fused, fused_colors);
  frame.fused_points = fused.size(0);
  const std::string report = rig_json(frame);
  io::write_file_atomically((staged.path() / "rig.json").string(),
                            [&](std::ostream& out) { out << report; });
  staged.commit();
}

RigPredictJobSummary JobRun::run() {
  if (!io::image_io_available())
    throw std::runtime_error("this build has no image file I/O (OpenCV)");
  options_.Check();
  rig_ = io::read_rig(options_.rig);
  for (const char* file : {"fused.ply", "fused.glb", "rig.json"})
    if (rig_.find(file) != nullptr)
      throw std::invalid_argument(options_.rig + ": a camera named " + file +
                                  " would overwrite the frame's " + file + "; rename it");
  if (!options_.lidar_format.empty())
    lidar_floats_per_point_ = io::lidar_floats_per_point(options_.lidar_format);
  else if (rig_.lidar)
    lidar_floats_per_point_ = rig_.lidar->floats_per_point;
  const std::vector<std::string> frames = list_frames(options_.frames_dir);
  summary_.frames = static_cast<int64_t>(frames.size());
  frame_count_ = frames.size();
  std::map<size_t, FinishedFrame> finished;  // with sequence: by an earlier run
  if (options_.sequence)
    for (size_t i = 0; i < frames.size(); ++i)
      if (auto frame = finished_frame(fs::path(options_.output_dir) / frames[i], options_.scale))
        finished.emplace(i, *frame);
  predictor_ = options_.predictor;
  if (!predictor_) {
    const Model model = Model::load(options_.model_path, options_.device);
    predictor_ = [model](const RigCameraImage& image, const PredictOptions& options) {
      return model.predict(image.image, options);
    };
  }

  observer_.start(rig_, frames);
  // The next unfinished frame is read while the network runs on this one.
  const auto next_to_predict = [&](size_t from) {
    while (from < frames.size() && finished.count(from) > 0) ++from;
    return from;
  };
  const auto read_async = [&](size_t index) {
    return std::async(std::launch::async, [this, &frames, index] {
      FrameInput input;
      try {
        read_frame(frames[index], input);
      } catch (...) {
        input.error = std::current_exception();
      }
      return input;
    });
  };
  std::future<FrameInput> upcoming;
  if (const size_t first = next_to_predict(0); first < frames.size()) upcoming = read_async(first);
  for (size_t i = 0; i < frames.size(); ++i) {
    observer_.frame_started(i, frames[i]);
    if (const auto done = finished.find(i); done != finished.end()) {
      double applied = 0;
      sequence_scale_ = advanced_scale(done->second.frame_rig_scale, applied);
      ++summary_.resumed;
      observer_.frame_resumed(i, frames[i], done->second.rig_scale);
      observer_.frame_done(i);
      continue;
    }
    try {
      std::future<FrameInput> current = std::exchange(upcoming, {});
      if (const size_t next = next_to_predict(i + 1); next < frames.size())
        upcoming = read_async(next);
      frame_index_ = i;
      const RigFrameResult frame = predict_frame(current.get());
      if (sequence_scale_after_) sequence_scale_ = std::exchange(sequence_scale_after_, {});
      ++summary_.written;
      observer_.frame_written(frame);
    } catch (const std::exception& e) {
      ++summary_.failed;
      observer_.frame_failed(frames[i], e.what());
    }
    observer_.frame_done(i);
  }
  observer_.finished(summary_);
  return summary_;
}

}  // namespace

void RigPredictJobOptions::Check() const {
  const auto fail = [](const std::string& text) { throw std::invalid_argument(text); };
  if (rig.empty()) fail("--rig: no rig file given");
  if (frames_dir.empty()) fail("--rig: no frames folder given");
  if (!lidar_format.empty()) io::lidar_floats_per_point(lidar_format);  // throws when unknown
  if (model_path.empty() && !predictor) fail("--model: no model given");
  if (max_size < 0) fail("--max-size " + std::to_string(max_size) + ": expected >= 0");
  if (num_tokens < 0) fail("--num-tokens " + std::to_string(num_tokens) + ": expected >= 0");
  if (!(edge_rtol >= 0) || !std::isfinite(edge_rtol))
    fail("--edge-threshold " + number(edge_rtol) + ": expected a number >= 0");
  if (output_dir.empty()) fail("--out: no output folder given");
  const std::set<std::string> known = all_output_files();
  for (const std::string& file : output_files)
    if (known.count(file) == 0) fail("--outputs: unknown file \"" + file + "\"");
}

std::string describe(const RigFrameResult& frame) {
  std::string text = frame.name + " -> " + frame.folder + " (" +
                     std::to_string(frame.cameras.size()) + " camera(s), " +
                     std::to_string(frame.fused_points) + " points in the body frame, rig scale " +
                     number(frame.rig_scale, 4);
  if (frame.frame_rig_scale != frame.rig_scale)
    text += " (the frame's own " + number(frame.frame_rig_scale, 4) + ")";
  if (!frame.lidar.empty()) text += ", LiDAR " + fs::path(frame.lidar).filename().string();
  if (frame.overlap_residual)
    text += ", overlap residual " + number(100 * *frame.overlap_residual, 3) + "%";
  for (const RigCameraResult& camera : frame.cameras) {
    text += ", " + camera.name + " " + number(camera.scale, 4) + " " + camera.scale_source;
    if (std::abs(camera.disagreement) >= 5e-5)
      text += " " + std::string(camera.disagreement > 0 ? "+" : "") +
              number(100 * camera.disagreement, 3) + "%";
  }
  return text + ")";
}

RigPredictJob::RigPredictJob(RigPredictJobOptions options, RigPredictJobObserver* observer)
    : options_(std::move(options)), observer_(observer) {}

RigPredictJobSummary RigPredictJob::Run() {
  RigPredictJobObserver silent;
  return JobRun(options_, observer_ != nullptr ? *observer_ : silent).run();
}

}  // namespace omnipoint::predict
