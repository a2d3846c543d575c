// omnipoint predict: binds the options of predict::PredictJob (omnipoint/predict/predict_job.h),
// with --rig those of predict::RigPredictJob (omnipoint/predict/rig_predict_job.h; with
// --sequence too, the rig's video), or with --sequence alone those of
// predict::SequencePredictJob (omnipoint/predict/sequence_predict_job.h), and
// prints what it reports: a bad image or sparse-depth file skips that image with one line
// on stderr; inputs that look wrong get a warning line; the run ends with a summary that counts
// both, and a non-zero status when an image failed. --view then serves the outputs.
#include <CLI/CLI.hpp>

#include <cstdio>
#include <memory>
#include <stdexcept>
#include <string>

#include "cli/bundled.h"
#include "cli/commands.h"
#include "cli/device.h"
#include "cli/predict_reports.h"
#include "cli/threads.h"
#include "cli/view_server.h"
#include "omnipoint/io/atomic_file.h"
#include "omnipoint/io/point_cloud.h"
#include "omnipoint/predict/predict_job.h"
#include "omnipoint/predict/sequence_predict_job.h"

namespace omnipoint::cli {

namespace {

struct PredictCommandOptions {
  predict::PredictJobOptions job;  // what the options below do not need to translate
  std::string rig;                 // --rig: the rig file; the one input is the frames folder
  std::string lidar_format = "kitti";
  bool lidar_format_given = false;  // --rig: it overrides the rig file's
  bool sequence = false;            // --sequence: the one input is a folder of one camera's frames
  int64_t calibration_frames = 8;   // --sequence: the frames the camera is calibrated from
  std::string scale = "smooth";     // --sequence: fixed, smooth or per-frame
  std::string model_path;
  std::string outputs = "default";
  std::string fit_model = "auto";
  std::string device = "cpu";
  std::string precision = "auto";
  bool view = false;
  bool cached_writes = false;
  bool no_exif = false;
  int threads = 0;  // 0: every core
};

// --view: OUT in the browser, as `omnipoint view OUT` shows it.
void view_outputs(const std::string& output_dir) {
  ViewOptions view;
  view.dir = output_dir;
  serve_predictions(view);
}

// --rig: the job's options that apply to a rig, carried over.
void run_rig_predict(const PredictCommandOptions& options) {
  const predict::PredictJobOptions& job = options.job;
  if (job.inputs.size() != 1)
    throw std::invalid_argument("--rig: expected one frames folder, got " +
                                std::to_string(job.inputs.size()) + " inputs");
  predict::RigPredictJobOptions rig;
  rig.rig = options.rig;
  rig.frames_dir = job.inputs.front();
  if (options.lidar_format_given) rig.lidar_format = options.lidar_format;
  rig.model_path = job.model_path;
  rig.device = job.device;
  rig.precision = job.precision;
  rig.max_size = job.max_size;
  rig.num_tokens = job.num_tokens;
  rig.edge_rtol = job.edge_rtol;
  rig.output_dir = job.output_dir;
  rig.output_files = job.output_files;
  rig.sequence = options.sequence;
  rig.scale = predict::parse_scale_mode(options.scale);
  RigPredictReports reports;
  const predict::RigPredictJobSummary summary = predict::RigPredictJob(rig, &reports).Run();
  if (summary.failed > 0)
    throw std::runtime_error(std::to_string(summary.failed) + " of " +
                             std::to_string(summary.frames) + " frames failed (see above)");
  if (options.view) view_outputs(job.output_dir);
}

// --sequence: the job's options that apply to a sequence, carried over.
void run_sequence_predict(const PredictCommandOptions& options) {
  const predict::PredictJobOptions& job = options.job;
  if (job.inputs.size() != 1)
    throw std::invalid_argument("--sequence: expected one frames folder, got " +
                                std::to_string(job.inputs.size()) + " inputs");
  predict::SequencePredictJobOptions sequence;
  sequence.frames_dir = job.inputs.front();
  sequence.camera = job.camera;
  sequence.calibration_frames = options.calibration_frames;
  sequence.scale = predict::parse_scale_mode(options.scale);
  sequence.use_exif = job.use_exif;
  sequence.model_path = job.model_path;
  sequence.device = job.device;
  sequence.precision = job.precision;
  sequence.max_size = job.max_size;
  sequence.num_tokens = job.num_tokens;
  sequence.edge_rtol = job.edge_rtol;
  sequence.output_dir = job.output_dir;
  sequence.output_files = job.output_files;
  SequencePredictReports reports;
  const predict::SequencePredictJobSummary summary =
      predict::SequencePredictJob(sequence, &reports).Run();
  if (summary.failed > 0)
    throw std::runtime_error(std::to_string(summary.failed) + " of " +
                             std::to_string(summary.frames) + " frames failed (see above)");
}

void run_predict(PredictCommandOptions& options) {
  if (options.view && !viewer_available())
    throw std::runtime_error(
        "--view: this omnipoint was built without the viewer (OMNIPOINT_WITH_VIEWER=OFF)");
  predict::PredictJobOptions& job = options.job;
  job.lidar_floats_per_point = io::lidar_floats_per_point(options.lidar_format);
  job.device = parse_device(options.device);
  job.precision = parse_precision(options.precision, job.device);
  job.fit_model = options.fit_model == "none" ? "" : options.fit_model;
  job.use_exif = !options.no_exif;
  job.output_files = predict::parse_output_list(options.outputs);
  if (bundled_model_chosen(options.model_path))
    std::fprintf(stderr, "omnipoint: note: %s\n", kBundledModelNote);
  job.model_path = model_path_or_bundled(options.model_path);
  if (!options.rig.empty()) {
    run_rig_predict(options);
    return;
  }
  if (options.sequence) {
    run_sequence_predict(options);
  } else {
    PredictReports reports;
    const predict::PredictJobSummary summary = predict::PredictJob(job, &reports).Run();
    if (summary.failed > 0)
      throw std::runtime_error(std::to_string(summary.failed) + " of " +
                               std::to_string(summary.images) + " images failed (see above)");
  }
  if (options.view) view_outputs(job.output_dir);
}

// --sequence and its own options.
void add_sequence_options(CLI::App* command, PredictCommandOptions& options) {
  CLI::Option* sequence = command->add_flag(
      "--sequence", options.sequence,
      "The one input is a folder of one camera's frames (a video's), in name order: one camera "
      "for all (--camera, else calibrated from the first frames), a metric scale that follows a "
      "running estimate (--scale), frames written as they finish; a rerun into the same --out "
      "resumes where an interrupted one stopped. With --rig: the frames folder is the rig's "
      "video, the rig scale follows the running estimate (docs/RIG.md)");
  CLI::Option* calibration = command
                                 ->add_option("--calibration-frames", options.calibration_frames,
                                              "--sequence: the first frames the camera (without "
                                              "--camera) and the fixed scale come from (not with "
                                              "--rig: the rig gives the cameras)")
                                 ->capture_default_str();
  CLI::Option* scale =
      command
          ->add_option("--scale", options.scale,
                       "--sequence: the applied metric scale: fixed (the calibration frames' "
                       "median; with --rig the first frame's rig scale), smooth (a robust running "
                       "estimate in log space, predict/scale_smoother.h) or per-frame (the "
                       "network's own; with --rig each frame's rig scale)")
          ->capture_default_str()
          ->check(CLI::IsMember({"fixed", "smooth", "per-frame"}));
  calibration->needs(sequence);
  calibration->excludes("--rig");
  scale->needs(sequence);
  for (const char* other : {"--fov", "--colmap", "--sparse-depth", "--sparse-depth-radial",
                            "--lidar-to-camera", "--fit-model"})
    sequence->excludes(other);
}

// Inputs: the images, their cameras, their sparse depth.
void add_input_options(CLI::App* command, PredictCommandOptions& options) {
  predict::PredictJobOptions& job = options.job;
  command->add_option("images", job.inputs, "Image files or folders of images")->required();
  command->add_option(
      "--camera", job.camera,
      "Camera of the images: a COLMAP-style spec \"MODEL W H PARAMS...\" (a leading camera id is "
      "allowed), a JSON object, a cameras.txt (FILE#ID picks one), a camera.json written by "
      "predict, or a UniK3D camera JSON (default: a JPEG's EXIF focal length as a centred "
      "pinhole, else the model predicts it)");
  command->add_flag("--no-exif", options.no_exif,
                    "Ignore the photos' EXIF data: the pixels as stored (no Orientation applied) "
                    "and no camera from its focal length");
  command
      ->add_option("--fov", job.fov_deg,
                   "Horizontal field of view in degrees of a pinhole camera centred in each "
                   "image (instead of --camera)")
      ->check(CLI::Range(1.0, 179.0));
  command->add_option(
      "--colmap", job.colmap,
      "A COLMAP sparse model folder (cameras, images, points3D as .bin or .txt): each image gets "
      "its camera and, from the points it observes, sparse depth; outputs gain points_world.ply "
      "and OUT/fused.ply in the reconstruction's frame and units");
  command->add_option(
      "--sparse-depth", job.sparse_depth,
      "Sparse depth: a depth map (16-bit PNG, see --depth-scale; .npy or .exr in metres; 0 = "
      "missing) or a point cloud (.ply, .pcd, .bin); a folder holds one file per image name");
  command->add_flag("--sparse-depth-radial", job.sparse_depth_radial,
                    "The sparse depth map holds radial distance along each pixel's ray, not planar "
                    "depth z (panoramas, range images)");
  command
      ->add_option("--depth-scale", job.depth_png_units_per_metre,
                   "Depth PNG values per metre (default 1000: millimetres; 256 for KITTI)")
      ->check(CLI::PositiveNumber);
  command->add_option(
      "--lidar-to-camera", job.lidar_to_camera,
      "Camera-from-LiDAR transform of point clouds: 4x4 or 3x4 numbers in a text file, a KITTI "
      "calib_velo_to_cam.txt (R, T) or odometry calib.txt (Tr), or a .npy");
  command
      ->add_option("--lidar-format", options.lidar_format,
                   "Record layout of .bin scans: kitti (x y z intensity), nuscenes (x y z "
                   "intensity ring) or the number of float32 values per point")
      ->capture_default_str();
  CLI::Option* rig = command->add_option(
      "--rig", options.rig,
      "A rig file (docs/RIG.md): the one input is then a folder of frames, FRAMES/<frame>/ "
      "holding <camera name>.jpg (or .png, ...) per camera and optionally a LiDAR sweep "
      "lidar.bin|ply|pcd; writes OUT/<frame>/<camera>/, fused.ply (every camera's points in the "
      "body frame) and rig.json (the cameras' scales)");
  for (const char* other :
       {"--camera", "--fov", "--colmap", "--sparse-depth", "--sparse-depth-radial", "--depth-scale",
        "--lidar-to-camera", "--no-exif"})
    rig->excludes(other);
}

// The network: which model, where, at what size and precision.
void add_network_options(CLI::App* command, PredictCommandOptions& options) {
  predict::PredictJobOptions& job = options.job;
  command->add_option(
      "--model", options.model_path,
      "Model checkpoint: a file (.safetensors or PyTorch .pt, OmniPoint or MoGe-2), or a "
      "published one fetched into the cache, hf:OWNER/REPO[/FILE][@REVISION] or a short name "
      "such as moge-2-vitl-normal (omnipoint models) (default: $OMNIPOINT_MODEL, else the "
      "bundled models/omnipoint_default.safetensors)");
  command
      ->add_option("--max-size", job.max_size,
                   "Longest image side for the network and the outputs (the camera is rescaled; "
                   "default: the image's own size)")
      ->check(CLI::PositiveNumber);
  command
      ->add_option("--edge-threshold", job.edge_rtol,
                   "Flying-pixel filter (MoGe's): drop pixels whose 3x3 neighbourhood's distances "
                   "span more than this fraction of their own (0: off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  command->add_option("--num-tokens", job.num_tokens, "ViT token budget (default: the model's)")
      ->check(CLI::PositiveNumber);
  command->add_option(
      "--fit-model", options.fit_model,
      "Camera model fitted to the predicted rays (COLMAP name; auto: a given camera as it is, else "
      "the simplest candidate of the smallest angular residual, camera/fit.h; none: no fit)");
  command->add_option("--device", options.device, "cpu, cuda or cuda:N (default cpu)");
  command->add_option("--precision", options.precision, kPrecisionHelp)->capture_default_str();
  add_threads_option(command, &options.threads);
}

// The outputs: where, which files, how they are written, and --view after.
void add_output_options(CLI::App* command, PredictCommandOptions& options) {
  predict::PredictJobOptions& job = options.job;
  command->add_option("--out", job.output_dir, "Output folder (default: predictions)");
  command
      ->add_option("--outputs", options.outputs,
                   "Files to write, comma-separated: ply, glb, npy (points, distance, depth, rays, "
                   "normals), depth (depth.png, distance.png), mask, vis, preview, png (all PNGs), "
                   "mesh (mesh.glb), default (all but the mesh), all, or file names; camera.json "
                   "is always written")
      ->capture_default_str();
  command->add_flag("--view", options.view,
                    "When every image (or rig frame) is written, show OUT in the browser as "
                    "`omnipoint view OUT` does (Ctrl-C stops)");
  command->add_flag("--cached-writes", options.cached_writes,
                    "Write files over 4 MiB through the page cache, not with direct I/O: better "
                    "for a single large prediction on a slow disk (SD card, eMMC, network "
                    "file system)");
}

}  // namespace

void add_predict_command(CLI::App& app) {
  auto options = std::make_shared<PredictCommandOptions>();
  CLI::App* command = app.add_subcommand(
      "predict",
      "Predict a 3D point cloud from each image (files, or folders searched recursively; every "
      "format OpenCV decodes); writes OUT/<image path>/ with points.ply/.glb, .npy maps, PNG "
      "maps, a preview and camera.json (--outputs chooses); with --rig, a rig's frames into one "
      "cloud per frame in the body frame");
  add_input_options(command, *options);
  add_network_options(command, *options);
  add_output_options(command, *options);
  add_sequence_options(command, *options);
  command->get_option("--rig")->excludes("--fit-model");
  command->callback([options, command] {
    options->lidar_format_given = command->count("--lidar-format") > 0;
    use_threads(options->threads);
    io::set_large_file_writes(options->cached_writes ? io::LargeFileWrites::page_cache
                                                     : io::LargeFileWrites::direct);
    run_predict(*options);
  });
}

}  // namespace omnipoint::cli
