// EXIF facts (io/exif.h): JPEG files whose EXIF segment the test composes (either byte order)
// read back as written; values that mean "unknown" are left out; the Orientation values turn
// an image as the standard describes them.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "omnipoint/io/exif.h"
#include "support/exif_jpeg.h"
#include "support/scratch_dir.h"

namespace omnipoint::io {
namespace {

namespace fs = std::filesystem;

class ExifTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!exif_available()) GTEST_SKIP() << "built without libexif (no image I/O)";
    dir_ = test::fresh_process_dir("omnipoint_exif");
  }
  void TearDown() override { fs::remove_all(dir_); }
  // A JPEG of markers alone (SOI, APP1, EOI): all a reader of EXIF looks at.
  std::string write(const std::string& name, const test::ExifTags& tags) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << test::jpeg_with_exif("\xFF\xD8\xFF\xD9", tags);
    return path;
  }
  fs::path dir_;
};

TEST_F(ExifTest, The35mmFocalLengthOrientationAndMakeReadBack) {
  test::ExifTags tags;
  tags.orientation = 6;
  tags.focal_length_35mm = 28;
  tags.make = "TestCam";
  const ExifFacts facts = read_exif(write("little.jpg", tags));
  EXPECT_TRUE(facts.present);
  EXPECT_EQ(facts.orientation, 6);
  ASSERT_TRUE(facts.focal_length_35mm.has_value());
  EXPECT_DOUBLE_EQ(*facts.focal_length_35mm, 28.0);
  EXPECT_FALSE(facts.focal_length.has_value());
  EXPECT_FALSE(facts.focal_plane_pixels_per_mm.has_value());
  EXPECT_EQ(facts.make, "TestCam");
}

TEST_F(ExifTest, TheFocalLengthAndSensorDensityReadBackInBigEndianFiles) {
  test::ExifTags tags;
  tags.big_endian = true;
  tags.focal_length = std::make_pair(42u, 10u);  // 4.2 mm
  tags.focal_plane_x_resolution = std::make_pair(1000u, 1u);
  tags.focal_plane_resolution_unit = 3;  // per centimetre: 100 pixels per mm
  tags.pixel_x_dimension = 4000;
  const ExifFacts facts = read_exif(write("big.JPG", tags));
  EXPECT_TRUE(facts.present);
  EXPECT_EQ(facts.orientation, 1);
  ASSERT_TRUE(facts.focal_length.has_value());
  EXPECT_DOUBLE_EQ(*facts.focal_length, 4.2);
  ASSERT_TRUE(facts.focal_plane_pixels_per_mm.has_value());
  EXPECT_DOUBLE_EQ(*facts.focal_plane_pixels_per_mm, 100.0);
  ASSERT_TRUE(facts.pixel_x_dimension.has_value());
  EXPECT_EQ(*facts.pixel_x_dimension, 4000);
  // The standard's default unit is the inch.
  tags.focal_plane_resolution_unit.reset();
  EXPECT_DOUBLE_EQ(*read_exif(write("inch.jpg", tags)).focal_plane_pixels_per_mm, 1000 / 25.4);
}

TEST_F(ExifTest, UnknownValuesAreLeftOut) {
  test::ExifTags tags;
  tags.orientation = 9;                        // no such orientation
  tags.focal_length_35mm = 0;                  // the standard's "unknown"
  tags.focal_length = std::make_pair(5u, 0u);  // no number
  tags.focal_plane_x_resolution = std::make_pair(100u, 1u);
  tags.focal_plane_resolution_unit = 1;  // no absolute unit
  const ExifFacts facts = read_exif(write("unknown.jpg", tags));
  EXPECT_TRUE(facts.present);
  EXPECT_EQ(facts.orientation, 1);
  EXPECT_FALSE(facts.focal_length_35mm.has_value());
  EXPECT_FALSE(facts.focal_length.has_value());
  EXPECT_FALSE(facts.focal_plane_pixels_per_mm.has_value());
}

TEST_F(ExifTest, FilesWithoutExifHaveNone) {
  const std::string plain = (dir_ / "plain.jpg").string();
  std::ofstream(plain, std::ios::binary) << "\xFF\xD8\xFF\xD9";
  EXPECT_FALSE(read_exif(plain).present);
  // Only JPEG files are read: EXIF bytes in a PNG's name are not looked at.
  test::ExifTags tags;
  tags.orientation = 3;
  const std::string png = write("picture.png", tags);
  EXPECT_FALSE(read_exif(png).present);
  EXPECT_THROW(read_exif((dir_ / "missing.jpg").string()), std::runtime_error);
}

// Each value against the standard's words: where the stored 0th row and 0th column go.
TEST(ExifOrientation, EachValueTurnsTheImageAsTheStandardSays) {
  const int64_t H = 2, W = 3;
  const at::Tensor stored = at::arange(H * W * 2, at::kFloat).reshape({H, W, 2});
  // displayed(i, j) = stored(row(i, j), column(i, j)).
  const auto expected = [&](int orientation, int64_t i, int64_t j) {
    switch (orientation) {
      case 2:
        return stored[i][W - 1 - j];  // row 0 top, column 0 right
      case 3:
        return stored[H - 1 - i][W - 1 - j];  // row 0 bottom, column 0 right
      case 4:
        return stored[H - 1 - i][j];  // row 0 bottom, column 0 left
      case 5:
        return stored[j][i];  // row 0 left, column 0 top
      case 6:
        return stored[H - 1 - j][i];  // row 0 right, column 0 top
      case 7:
        return stored[H - 1 - j][W - 1 - i];  // row 0 right, column 0 bottom
      case 8:
        return stored[j][W - 1 - i];  // row 0 left, column 0 bottom
      default:
        return stored[i][j];
    }
  };
  for (int orientation = 0; orientation <= 9; ++orientation) {
    const at::Tensor shown = apply_exif_orientation(stored, orientation);
    const bool swapped = orientation_swaps_axes(orientation);
    EXPECT_EQ(swapped, orientation >= 5 && orientation <= 8);
    ASSERT_EQ(shown.size(0), swapped ? W : H) << orientation;
    ASSERT_EQ(shown.size(1), swapped ? H : W) << orientation;
    for (int64_t i = 0; i < shown.size(0); ++i)
      for (int64_t j = 0; j < shown.size(1); ++j)
        EXPECT_TRUE(at::equal(shown[i][j], expected(orientation, i, j)))
            << "orientation " << orientation << " at " << i << "," << j;
  }
}

}  // namespace
}  // namespace omnipoint::io
