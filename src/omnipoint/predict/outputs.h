#pragma once
// The files of one prediction (the per-image folder of `omnipoint predict`):
//   points.ply      binary PLY, coloured, valid points only (metres, camera frame)
//   points.glb      the same cloud as a glTF 2.0 binary POINTS primitive (io/glb.h)
//   points.npy      (H, W, 3) float32 metric points, 0 where invalid (the PLY's source; the
//                   point map `omnipoint eval` scores)
//   distance.npy    (H, W) float32 metric radial distance, 0 where invalid
//   depth.npy       (H, W) float32 planar depth z, 0 where invalid
//   rays.npy        (H, W, 3) float32 unit rays
//   normals.npy     (H, W, 3) float32 unit normals facing the camera, from the points
//                   (geometry::normals_from_point_map), 0 where invalid
//   mask.png        8-bit, 255 = valid
//   depth.png       16-bit planar depth in millimetres (metres = value / 1000, up to 65.535 m)
//   distance.png    16-bit radial distance in 1/256 m (metres = value / 256, up to 255.996 m,
//                   KITTI's depth-PNG scale): panoramas and fisheyes, whose planar depth is <= 0
//                   behind the camera, keep every pixel here
//                   In both PNGs 0 = invalid or not representable (behind the camera, beyond
//                   the range or under half a unit); camera.json gives scale, range and counts.
//   depth_vis.png   colour-mapped inverse depth (distance, so panoramas colour too)
//   preview.png     the cloud from an oblique viewpoint (preview.h)
//   image.png       8-bit RGB, the image the prediction was made from (at its size, after
//                   --max-size), so that the folder shows it beside its maps (`omnipoint view`)
//   points_world.ply  with a camera-from-world pose (OutputOptions): the valid points in that
//                   world frame (`predict --colmap`: the reconstruction's frame and units)
//   mesh.glb        grid triangulation of the point map (geometry::grid_mesh) with the image's
//                   colours, cells across depth edges skipped; only when asked for
//   camera.json     always, the run's record: the camera (JSON "camera", "camera_spec" MODEL W H
//                   PARAMS, "cameras_txt_line" 1 MODEL W H PARAMS, fields of view;
//                   "camera_source" given|exif|fitted and, when fitted, "fit_residual_deg"
//                   median/max; with a given or EXIF camera and a network that predicts rays,
//                   "camera_vs_network_rays_deg" mean/median/max: the angle between the two),
//                   metric scale, alignment, edge filter, the files written and the
//                   PNGs' scales, notes, warnings and per-stage and per-file timing (writing
//                   included); `--camera camera.json` reads it back
//   cameras.txt     the camera as a COLMAP cameras.txt (camera id 1), when there is one
// The folder appears complete or not at all: everything is written into a staging sibling
// (io::StagedFolder) which is then renamed over `folder` (an older folder of that name is
// replaced); a run killed midway leaves a staging folder that the next one removes.
#include <ATen/core/Tensor.h>

#include <set>
#include <string>

#include "omnipoint/predict/predictor.h"

namespace omnipoint::predict {

// Every file above but points_world.ply (which comes with a pose) and cameras.txt (which comes
// with a camera).
std::set<std::string> all_output_files();
// Every file above but mesh.glb (it doubles the size and is asked for by name).
std::set<std::string> default_output_files();

struct OutputOptions {
  std::set<std::string> files = default_output_files();  // file names; camera.json is implied
  // mesh.glb skips the cells with a corner on a depth edge at this tolerance
  // (geometry::depth_edge_mask; 0: none). After predict's filter at the same tolerance there
  // are none left; this keeps the mesh clean when that filter was off.
  double mesh_edge_rtol = kDefaultEdgeRtol;
  // A (4, 4) camera-from-world pose (a COLMAP image's): points_world.ply is written too, the
  // valid points in that world frame, and camera.json records the pose.
  at::Tensor camera_from_world;
  // A JSON object whose members camera.json records too (`predict --sequence`'s "sequence"
  // record); "": none.
  std::string camera_json_extra;
};

// The `--outputs` list: comma-separated group names or file names, e.g. "ply,npy,mesh":
//   ply points.ply · glb points.glb · npy the five .npy · depth depth.png + distance.png ·
//   mask mask.png · vis depth_vis.png · preview preview.png · image image.png · png the six .png ·
//   mesh mesh.glb · camera camera.json only · default default_output_files() · all every file
// camera.json is always written. Unknown or empty names -> std::invalid_argument listing the
// valid ones.
std::set<std::string> parse_output_list(const std::string& list);

// image (H, W, 3) RGB in [0, 1] (float) or uint8, the image the prediction was made from.
// Writes options.files (only those are computed: no preview render unless asked for).
// Returns the milliseconds spent writing.
double write_prediction_outputs(const std::string& folder, const at::Tensor& image,
                                const Prediction& prediction, const OutputOptions& options = {});

// camera.json's content (without the writing time and the files).
std::string prediction_summary_json(const Prediction& prediction);

}  // namespace omnipoint::predict
