// Feature classes from hand-made principal curvatures, both detection modes.
#include "pointfair/features.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "pointfair/params_error.hpp"

namespace pointfair {
namespace {

Curvature curvature(double k1, double k2) {
  Curvature c;
  c.k1 = std::max(k1, k2);
  c.k2 = std::min(k1, k2);
  c.mean = 0.5 * (k1 + k2);
  c.valid = true;
  return c;
}

constexpr double kThreshold = 10.0;
constexpr double kQuotient = 0.5;

TEST(Features, EdgeQuotientMode) {
  const auto cls = [](double k1, double k2) {
    return classify_feature(curvature(k1, k2), FeatureMode::EdgeQuotient, kQuotient, kThreshold);
  };
  EXPECT_EQ(cls(0.0, 0.0), FeatureClass::Smooth) << "flat";
  EXPECT_EQ(cls(9.9, 0.1), FeatureClass::Smooth) << "below the threshold";
  EXPECT_EQ(cls(5.0, 5.0), FeatureClass::Smooth) << "umbilic but weak";
  EXPECT_EQ(cls(20.0, 1.0), FeatureClass::Edge) << "q = 0.05";
  EXPECT_EQ(cls(0.5, -20.0), FeatureClass::Edge) << "signs do not matter, |k_max| = 20";
  EXPECT_EQ(cls(10.0, 0.0), FeatureClass::Edge) << "|k_max| = threshold counts";
  EXPECT_EQ(cls(20.0, 9.9), FeatureClass::Edge) << "q = 0.495 < Q";
  EXPECT_EQ(cls(20.0, 10.0), FeatureClass::Corner) << "q = 0.5 is not < Q";
  EXPECT_EQ(cls(-30.0, -25.0), FeatureClass::Corner);
  EXPECT_EQ(cls(30.0, -25.0), FeatureClass::Corner) << "saddle-like corner";
  // Q = 0: nothing is an edge; Q = 1: everything but exact umbilics is an edge.
  EXPECT_EQ(classify_feature(curvature(20, 1), FeatureMode::EdgeQuotient, 0.0, kThreshold), FeatureClass::Corner);
  EXPECT_EQ(classify_feature(curvature(20, 19), FeatureMode::EdgeQuotient, 1.0, kThreshold), FeatureClass::Edge);
  EXPECT_EQ(classify_feature(curvature(20, 20), FeatureMode::EdgeQuotient, 1.0, kThreshold), FeatureClass::Corner);
}

TEST(Features, MaxCurvatureMode) {
  const auto cls = [](double k1, double k2) {
    return classify_feature(curvature(k1, k2), FeatureMode::MaxCurvature, kQuotient, kThreshold);
  };
  EXPECT_EQ(cls(0.0, 0.0), FeatureClass::Smooth);
  EXPECT_EQ(cls(9.0, -9.0), FeatureClass::Smooth);
  EXPECT_EQ(cls(12.0, 9.0), FeatureClass::Edge) << "only one principal curvature reaches T";
  EXPECT_EQ(cls(-3.0, -12.0), FeatureClass::Edge);
  EXPECT_EQ(cls(12.0, 10.0), FeatureClass::Corner) << "both reach T";
  EXPECT_EQ(cls(12.0, -11.0), FeatureClass::Corner);
}

TEST(Features, NoneModeInvalidCurvatureAndZeroThreshold) {
  EXPECT_EQ(classify_feature(curvature(100, 90), FeatureMode::None, kQuotient, kThreshold), FeatureClass::Smooth);
  Curvature invalid = curvature(100, 90);
  invalid.valid = false;
  EXPECT_EQ(classify_feature(invalid, FeatureMode::EdgeQuotient, kQuotient, kThreshold), FeatureClass::Smooth);
  EXPECT_EQ(classify_feature(invalid, FeatureMode::MaxCurvature, kQuotient, kThreshold), FeatureClass::Smooth);
  // A zero threshold must not make flat points features (q = 0/0).
  EXPECT_EQ(classify_feature(curvature(0, 0), FeatureMode::EdgeQuotient, kQuotient, 0.0), FeatureClass::Smooth);
  EXPECT_EQ(classify_feature(curvature(0, 0), FeatureMode::MaxCurvature, kQuotient, 0.0), FeatureClass::Smooth);
  // NaN curvature: never a feature.
  EXPECT_EQ(classify_feature(curvature(std::nan(""), 0), FeatureMode::EdgeQuotient, kQuotient, kThreshold),
            FeatureClass::Smooth);
}

TEST(Features, ValidateRejectsBadParameters) {
  EXPECT_NO_THROW(FeatureParams{}.validate());
  FeatureParams p;
  p.quotient = -0.1;
  EXPECT_THROW(p.validate(), ParamError);
  p.quotient = 1.1;
  EXPECT_THROW(p.validate(), ParamError);
  p.quotient = 1.0;
  EXPECT_NO_THROW(p.validate());
  p.threshold = -1.0;
  EXPECT_THROW(p.validate(), ParamError);
  p.threshold = std::numeric_limits<double>::infinity();
  EXPECT_THROW(p.validate(), ParamError);
  p.threshold = std::nan("");
  EXPECT_THROW(p.validate(), ParamError);
}

}  // namespace
}  // namespace pointfair
