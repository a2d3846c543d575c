#pragma once
// PCL's .pcd point clouds (header VERSION .7: FIELDS SIZE TYPE COUNT WIDTH HEIGHT VIEWPOINT
// POINTS DATA; '#' comment lines), read as points for `--sparse-depth`:
// - DATA ascii, binary (records of every field in turn, little-endian) and binary_compressed
//   (uint32 compressed size, uint32 uncompressed size, then LZF data holding the fields one
//   after another, each for all points);
// - x, y and z are fields of TYPE F (SIZE 4 or 8), I or U (SIZE 1, 2, 4 or 8) with COUNT 1;
//   other fields (rgb, intensity, histograms with COUNT > 1, '_' padding) are skipped;
// - points with a non-finite coordinate (PCL's NaN for "no return") are dropped;
// - VIEWPOINT (the sensor pose) must be the identity `0 0 0 1 0 0 0`: the points are taken to
//   be in the sensor's frame, so a cloud with another viewpoint raises an error rather than
//   being read in a frame the camera-from-LiDAR transform does not expect.
// COUNT defaults to 1 and VIEWPOINT to the identity when absent; POINTS must equal
// WIDTH * HEIGHT. Anything else raises std::invalid_argument (std::runtime_error for an
// unreadable file), naming the file and the problem.
#include <ATen/core/Tensor.h>

#include <string>

namespace omnipoint::io {

// (N, 3) float32 x, y, z.
at::Tensor parse_pcd(const std::string& bytes, const std::string& name);
at::Tensor read_pcd(const std::string& path);

}  // namespace omnipoint::io
