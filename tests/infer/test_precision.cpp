// Reduced-precision inference (model/precision.h): bf16 on the MoGe-2 fixture and on the
// bundled model stays within a stated distance of fp32, the geometry comes back in fp32, the
// autocast state is restored, and what cannot run is refused.
#include <ATen/ATen.h>
#include <ATen/autocast_mode.h>
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "omnipoint/infer/infer.h"
#include "omnipoint/io/npy.h"
#include "omnipoint/model/precision.h"
#include "omnipoint/predict/predictor.h"

namespace omnipoint::infer {
namespace {

using model::Precision;

const std::string kFixture = std::string(OMNIPOINT_FIXTURE_DIR) + "/moge2_forward_a";
const std::string kBundled =
    std::string(OMNIPOINT_SOURCE_DIR) + "/models/omnipoint_default.safetensors";

// |a − b| / |b| per point, over the points where both are finite and b is not at the origin.
at::Tensor relative_point_error(const at::Tensor& a, const at::Tensor& b) {
  const at::Tensor norm = at::linalg_vector_norm(b, 2, {-1});
  const at::Tensor error = at::linalg_vector_norm(a - b, 2, {-1}) / norm;
  return error.masked_select(at::isfinite(error) & (norm > 1e-6));
}

// bf16 rounds each product's inputs to 8 significant bits (relative step 2^-8 = 0.4 %); the
// measured deviation of the fixture's points is well inside these bounds (docs/PERFORMANCE.md).
constexpr double kMedianTolerance = 0.01, kMaxTolerance = 0.05;

TEST(Precision, Bf16StaysNearFp32OnTheMoGe2Fixture) {
  const Network network = load_network(kFixture + "/model.safetensors");
  const at::Tensor image = io::read_npy(kFixture + "/input.npy");
  const RawOutput fp32 = forward(network, image, 300, Precision::kFloat32);
  const RawOutput bf16 = forward(network, image, 300, Precision::kBFloat16);
  // fp32 is the fixture's own result (parity untouched by the precision code).
  EXPECT_TRUE(
      at::allclose(fp32.points, io::read_npy(kFixture + "/expected_points.npy"), 1e-4, 1e-4));
  for (const at::Tensor& output : {bf16.points, bf16.mask, bf16.metric_scale, bf16.distance})
    EXPECT_EQ(output.scalar_type(), at::kFloat);
  const at::Tensor error = relative_point_error(bf16.points, fp32.points);
  ASSERT_GT(error.numel(), image.size(2) * image.size(3) / 2);
  EXPECT_LE(error.median().item<double>(), kMedianTolerance);
  EXPECT_LE(error.max().item<double>(), kMaxTolerance);
  EXPECT_GT(error.max().item<double>(), 0.0) << "bf16 ran in fp32";
  EXPECT_NEAR(bf16.metric_scale.item<double>() / fp32.metric_scale.item<double>(), 1.0,
              kMedianTolerance);
  EXPECT_LE((bf16.mask - fp32.mask).abs().max().item<double>(), kMaxTolerance);
}

TEST(Precision, Bf16PredictionOfTheBundledModelStaysNearFp32) {
  const predict::Model model = predict::Model::load(kBundled);
  at::manual_seed(4);
  const at::Tensor image = at::rand({96, 128, 3});
  predict::PredictOptions options;
  options.fit_model = "";
  const predict::Prediction fp32 = model.predict(image, options);
  options.precision = Precision::kBFloat16;
  const predict::Prediction bf16 = model.predict(image, options);
  EXPECT_EQ(bf16.points.scalar_type(), at::kFloat);
  EXPECT_EQ(bf16.precision, Precision::kBFloat16);
  const at::Tensor both = fp32.mask & bf16.mask;
  ASSERT_GT(both.sum().item<int64_t>(), image.size(0) * image.size(1) / 2);
  const at::Tensor error =
      relative_point_error(bf16.points.index({both}), fp32.points.index({both}));
  EXPECT_LE(error.median().item<double>(), kMedianTolerance);
  EXPECT_LE(error.max().item<double>(), kMaxTolerance);
  EXPECT_NEAR(bf16.metric_scale / fp32.metric_scale, 1.0, kMedianTolerance);
}

TEST(Precision, ScopesRestoreTheAutocastState) {
  ASSERT_FALSE(at::autocast::is_cpu_enabled());
  {
    const model::AutocastScope scope(Precision::kBFloat16, c10::DeviceType::CPU);
    EXPECT_TRUE(at::autocast::is_cpu_enabled());
    EXPECT_EQ(at::autocast::get_autocast_cpu_dtype(), at::kBFloat16);
    EXPECT_EQ(at::mm(at::ones({2, 2}), at::ones({2, 2})).scalar_type(), at::kBFloat16);
    {
      const model::AutocastOff off;
      EXPECT_FALSE(at::autocast::is_cpu_enabled());
      EXPECT_EQ(at::mm(at::ones({2, 2}), at::ones({2, 2})).scalar_type(), at::kFloat);
    }
    EXPECT_TRUE(at::autocast::is_cpu_enabled());
  }
  EXPECT_FALSE(at::autocast::is_cpu_enabled());
  {
    const model::AutocastScope fp32(Precision::kFloat32, c10::DeviceType::CPU);
    EXPECT_FALSE(at::autocast::is_cpu_enabled());
  }
}

TEST(Precision, NamesAndRefusals) {
  for (const Precision p : {Precision::kFloat32, Precision::kBFloat16, Precision::kFloat16})
    EXPECT_EQ(model::parse_precision(model::precision_name(p)), p);
  EXPECT_THROW(model::parse_precision("fp8"), std::invalid_argument);
  EXPECT_THROW(model::AutocastScope(Precision::kFloat16, c10::DeviceType::CPU),
               std::invalid_argument);
  EXPECT_FALSE(at::autocast::is_cpu_enabled()) << "a refused scope changed nothing";
}

}  // namespace
}  // namespace omnipoint::infer
