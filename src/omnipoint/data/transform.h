#pragma once
// Geometric sample transforms that keep image, labels and camera consistent: the new
// camera (Camera::cropped / Camera::resized) unprojects the new distance map to the same 3-D
// points as the original camera did at the same image positions.
#include <cstdint>

#include "omnipoint/data/sample.h"

namespace omnipoint::data {

// The window [x0, x0 + width) x [y0, y0 + height), which must lie inside the image (exact).
Sample crop_sample(const Sample& sample, int64_t x0, int64_t y0, int64_t width, int64_t height);

// Resampled to width x height: the image bilinearly (area-averaged when shrinking), the
// distance and mask by nearest neighbour (never mixing foreground and background depths);
// sparse labels (Sample::sparse_labels) each to the new pixel holding its pixel centre, so
// that none is lost to the subsampling grid (geometry::resize_sparse_map).
Sample resize_sample(const Sample& sample, int64_t width, int64_t height);

// The largest centred window of the sample with the aspect ratio of width x height, resized to
// it (the sample itself when it has that size).
Sample fit_sample(const Sample& sample, int64_t width, int64_t height);

}  // namespace omnipoint::data
