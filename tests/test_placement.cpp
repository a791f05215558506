// SmoothParams::placement on a scan-like scene (a noisy ground with a box on it, 10 cm
// spacing, 1 cm noise): with the defaults the points move along the surface normal only, so
// that nothing slides along the ground and the open border stays where it was, while the
// noise across the ground is removed; the free flow (Placement::Free) slides them.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "pointfair/common/params_error.hpp"
#include "pointfair/smooth.hpp"
#include "support/clouds.hpp"

namespace pointfair {
namespace {

constexpr double kSpacing = 0.1, kSigma = 0.01, kHalf = 3.0, kBoxHalf = 0.8, kBoxHeight = 1.0;

double quantile(std::vector<double> values, double q) {
  const auto at = values.begin() + static_cast<std::ptrdiff_t>(q * static_cast<double>(values.size() - 1));
  std::nth_element(values.begin(), at, values.end());
  return *at;
}

struct Moves {
  std::vector<double> sideways;  // |xy move| of interior ground points
  std::vector<double> inward;    // move toward the interior of ground points near the border
  double rms_height_before = 0, rms_height_after = 0;
};

Moves moves_of(const test::GroundWithBox& scene, const std::vector<Vec3>& out) {
  Moves m;
  std::size_t interior = 0;
  for (std::size_t i = 0; i < out.size(); ++i) {
    if (!scene.ground[i]) continue;
    const Vec3& c = scene.clean[i];
    const Vec3 move = out[i] - scene.points[i];
    const double to_box = std::max(std::abs(c.x()), std::abs(c.y())) - kBoxHalf;
    const double to_border = kHalf - std::max(std::abs(c.x()), std::abs(c.y()));
    if (to_box > 4 * kSpacing && to_border > 4 * kSpacing) {
      m.sideways.push_back(std::hypot(move.x(), move.y()));
      m.rms_height_before += scene.points[i].z() * scene.points[i].z();
      m.rms_height_after += out[i].z() * out[i].z();
      ++interior;
    }
    if (to_border < 0.3) {
      // Toward the interior from the nearest side of the square.
      const bool along_x = std::abs(c.x()) >= std::abs(c.y());
      const double outward = along_x ? (c.x() > 0 ? move.x() : -move.x()) : (c.y() > 0 ? move.y() : -move.y());
      m.inward.push_back(-outward);
    }
  }
  m.rms_height_before = std::sqrt(m.rms_height_before / static_cast<double>(interior));
  m.rms_height_after = std::sqrt(m.rms_height_after / static_cast<double>(interior));
  return m;
}

class PlacementTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new test::GroundWithBox(test::ground_with_box(kHalf, kSpacing, kBoxHalf, kBoxHeight, kSigma, 7));
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }
  static std::vector<Vec3> run(const SmoothParams& params) {
    std::vector<Vec3> p = scene_->points;
    smooth(p, params);
    return p;
  }
  static test::GroundWithBox* scene_;
};
test::GroundWithBox* PlacementTest::scene_ = nullptr;

TEST_F(PlacementTest, DefaultsMoveAlongTheNormalAndKeepTheBorder) {
  const SmoothParams defaults;
  ASSERT_TRUE(defaults.finish.has_value());
  ASSERT_EQ(defaults.placement, Placement::AlongNormal);
  const Moves m = moves_of(*scene_, run(defaults));
  ASSERT_GT(m.sideways.size(), 1000u);
  ASSERT_GT(m.inward.size(), 100u);
  // The targets: the median sideways move of interior points at most 5% of the
  // spacing, the 95th percentile of the inward move near the border at most half a sigma.
  EXPECT_LE(quantile(m.sideways, 0.5), 0.05 * kSpacing);
  EXPECT_LE(quantile(m.inward, 0.95), 0.5 * kSigma);
  // ... while the noise across the ground is removed.
  EXPECT_LT(m.rms_height_after, 0.35 * m.rms_height_before)
      << "before " << m.rms_height_before << ", after " << m.rms_height_after;
}

TEST_F(PlacementTest, TheFreeFlowSlidesAlongTheGround) {
  // The same run with the free flow's positions: the test above could fail.
  SmoothParams free;
  free.placement = Placement::Free;
  const Moves m = moves_of(*scene_, run(free));
  EXPECT_GT(quantile(m.sideways, 0.5), 0.1 * kSpacing);
  EXPECT_GT(quantile(m.inward, 0.95), 2.0 * kSigma);
}

// The placement reads the caller's copy of the input when given one, and the flow's lists are
// let go when not wanted: the same bits either way. A copy that is not the input moves the
// result, so the copy is what the placement reads.
TEST(Placement, ReadsTheCallersInputCopyAndGivesTheSameBitsWithoutTheLists) {
  const test::GroundWithBox scene = test::ground_with_box(1.0, 0.1, 0.3, 0.4, 0.01, 5);
  const SmoothParams defaults;
  std::vector<Vec3> own = scene.points, lean = scene.points, shifted = scene.points;
  const SmoothReport own_report = smooth(own, defaults);
  EXPECT_EQ(own_report.neighborhoods.size(), own.size());
  SmoothOptions options;
  options.keep_neighborhoods = false;
  options.input_positions = scene.points;
  const SmoothReport lean_report = smooth(lean, defaults, options);
  EXPECT_EQ(lean, own);
  EXPECT_EQ(lean_report.neighborhoods.size(), 0u);
  EXPECT_EQ(lean_report.steps, own_report.steps);
  std::vector<Vec3> moved_input = scene.points;
  for (Vec3& p : moved_input) p += Vec3(0.02, 0.0, 0.0);
  options.input_positions = moved_input;
  smooth(shifted, defaults, options);
  EXPECT_NE(shifted, own);
  std::vector<Vec3> short_input(scene.points.begin(), scene.points.end() - 1);
  options.input_positions = short_input;
  std::vector<Vec3> refused = scene.points;
  EXPECT_THROW(smooth(refused, defaults, options), ParamError);
}

TEST(Placement, IsIgnoredWithoutTheFinish) {
  const test::GroundWithBox scene = test::ground_with_box(1.0, 0.1, 0.3, 0.4, 0.01, 3);
  SmoothParams along, free;
  along.finish.reset();
  free.finish.reset();
  free.placement = Placement::Free;
  std::vector<Vec3> a = scene.points, b = scene.points;
  const SmoothReport ra = smooth(a, along);
  smooth(b, free);
  EXPECT_EQ(a, b);
  EXPECT_FALSE(ra.placed_along_normal);
}

TEST(Placement, PaperParamsUseTheFreeFlowWithoutTheFinishAndLambdaFeatures) {
  const SmoothParams p = paper_smooth_params();
  EXPECT_FALSE(p.finish.has_value());
  EXPECT_EQ(p.placement, Placement::Free);
  EXPECT_EQ(p.flow.features.scale, FeatureScale::Lambda);
}

}  // namespace
}  // namespace pointfair
