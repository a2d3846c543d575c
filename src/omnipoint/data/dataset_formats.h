#pragma once
// The dataset formats built into the library, as one table (dataset_formats.cpp), each entry a
// reader's DatasetFormat (dataset.h). A new reader: its own file beside the others, its
// DatasetFormat declared here, one line in the table; its test writes files in the format's
// exact native layout with a known truth and reads them back (tests/data/).
#include <vector>

#include "omnipoint/data/dataset.h"

namespace omnipoint::data {

std::vector<DatasetFormat> builtin_dataset_formats();

DatasetFormat sample_folders_format();  // "folders": this project's sample folders (sample.h)
DatasetFormat moge_format();            // "moge": MoGe's evaluation benchmarks (moge_format.h)
// Driving and a rig's own logs.
DatasetFormat kitti_raw_format();  // "kitti-raw": KITTI raw recordings (formats/kitti_raw.cpp)
DatasetFormat kitti360_format();   // "kitti360": KITTI-360 (formats/kitti360.cpp)
DatasetFormat rig_log_format();    // "rig-log": a rig's own logs (formats/rig_log.cpp)
// Panoramas and indoor renderings (formats/<name>.cpp, each with its layout and conventions).
DatasetFormat stanford2d3d_format();
DatasetFormat matterport360_format();
DatasetFormat pano3d_format();
DatasetFormat panosuncg_format();
DatasetFormat structured3d_format();
// Rendered training sets (formats/<name>.cpp).
DatasetFormat hypersim_format();
DatasetFormat vkitti2_format();
// Pinhole RGB-D captures and renderings (formats/<name>.cpp).
DatasetFormat arkitscenes_format();
DatasetFormat tartanair_format();
// Unlabelled images with one camera (formats/images.cpp): A2P self-training's source.
DatasetFormat images_format();

}  // namespace omnipoint::data
