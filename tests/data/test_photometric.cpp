// Photometric augmentation: deterministic by seed, in range, the identity with every effect off.
#include <ATen/ATen.h>
#include <gtest/gtest.h>

#include "omnipoint/data/photometric.h"

namespace omnipoint::data {
namespace {

TEST(Photometric, DeterministicBySeedAndInRange) {
  const auto image = at::rand({20, 24, 3});
  PhotometricOptions o;
  o.blur_probability = o.noise_probability = o.jpeg_probability = 1.0;
  const auto a = photometric_augment(image, o, 5), b = photometric_augment(image, o, 5);
  const auto c = photometric_augment(image, o, 6);
  EXPECT_TRUE(at::equal(a, b));
  EXPECT_FALSE(at::equal(a, c));
  EXPECT_EQ(a.sizes(), image.sizes());
  EXPECT_GE(a.min().item<double>(), 0.0);
  EXPECT_LE(a.max().item<double>(), 1.0);
  // With every effect off the image is unchanged.
  PhotometricOptions none{0, 0, 0, 0, 0, 0, 0};
  EXPECT_TRUE(at::allclose(photometric_augment(image, none, 1), image, 1e-6, 1e-6));
}

}  // namespace
}  // namespace omnipoint::data
