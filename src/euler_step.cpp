#include "pointfair/euler_step.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cstdint>
#include <cstring>
#include <limits>
#include <cmath>
#include <string>
#include <vector>

#include "pointfair/parallel.hpp"
#include "pointfair/params_error.hpp"

namespace pointfair {

void FlowParams::validate() const {
  require(lambda >= 0.0 && std::isfinite(lambda),
          "lambda must be >= 0 (0 = automatic), got " + std::to_string(lambda));
  require(lambda_auto_factor > 0.0 && std::isfinite(lambda_auto_factor),
          "lambda auto factor must be positive, got " + std::to_string(lambda_auto_factor));
  require(tau > 0.0 && tau <= 1.0, "tau must be in (0, 1], got " + std::to_string(tau));
  features.validate();
  weingarten.validate();
  robust.validate();
}

PointState evaluate_point(const Vec3& p, std::span<const Index> neighbors,
                          std::span<const Vec3> points, const FlowParams& params, double lambda,
                          bool with_curvature) {
  PointState s;
  if (neighbors.empty()) return s;
  s.frame = params.normal_estimator == NormalEstimator::Robust
                ? compute_robust_frame(p, neighbors, points, params.robust)
                : compute_frame(p, neighbors, points);
  const bool needs_frame = params.flow == Flow::Anisotropic || params.constrain_normal ||
                           params.feature_gated || with_curvature;
  if (needs_frame && !s.frame.valid) return s;
  s.valid = true;

  const bool gated = params.feature_gated && params.features.mode != FeatureMode::None;
  if (with_curvature || gated) {
    s.curvature = compute_curvature(p, s.frame, neighbors, points, params.weingarten);
    const double threshold = params.features.threshold > 0.0 ? params.features.threshold : lambda;
    s.feature = classify_feature(s.curvature, params.features.mode, params.features.quotient,
                                 threshold);
  }
  Flow flow = params.flow;
  if (gated && s.feature == FeatureClass::Smooth) flow = Flow::Isotropic;
  // CutoffOrigin::Plane: the foot of p on the PCA plane, at height <n, c - p> along n.
  const double origin_height = params.cutoff_origin == CutoffOrigin::Plane
                                   ? s.frame.normal.dot(s.frame.centroid - p)
                                   : 0.0;
  s.laplacian = laplacian(p, s.frame.normal, neighbors, points,
                          {flow, params.cutoff, lambda, origin_height});
  s.displacement = params.constrain_normal
                       ? Vec3(params.tau * s.laplacian.dot(s.frame.normal) * s.frame.normal)
                       : Vec3(params.tau * s.laplacian);
  return s;
}

namespace {

// The step's hot path. One pass gathers the neighbour offsets d_j = p_j - p into small local
// arrays, one per coordinate (structure of arrays), padded with a zero to an even count; the
// sums of the covariance and of the cut-off then run over two neighbours at a time (GCC/Clang
// vector types: one SSE2 register, plain scalar code where there is none), one accumulator a
// quantity (more would spill). Each lane always sums the same neighbours in the same order, so
// the bits depend on nothing but the inputs. A zero offset adds nothing to any sum, so the
// padding changes no result. The cut-off is a mask, not a branch. Same formulas as
// evaluate_point (which the tests hold it against, with the plain reference in
// tests/support); evaluate_point classifies the points under feature gating and moves those
// with an unusually large neighbourhood.
constexpr std::size_t kLocalNeighbors = 64;
using Pair = double __attribute__((vector_size(2 * sizeof(double))));
using PairBits = std::int64_t __attribute__((vector_size(2 * sizeof(double))));

struct Offsets {
  // One more slot for the padding zero.
  alignas(sizeof(Pair)) double x[kLocalNeighbors + 2];
  alignas(sizeof(Pair)) double y[kLocalNeighbors + 2];
  alignas(sizeof(Pair)) double z[kLocalNeighbors + 2];
};

Pair load(const double* from) {
  Pair v;
  std::memcpy(&v, from, sizeof v);
  return v;
}
Pair splat(double x) { return Pair{x, x}; }
// The two lanes: even and odd neighbours.
double lane_sum(Pair s) { return s[0] + s[1]; }
// Keeps the lanes of v whose mask is all ones, zeroes the others.
Pair keep_if(Pair v, PairBits mask) {
  return std::bit_cast<Pair>(std::bit_cast<PairBits>(v) & mask);
}
Pair abs_lanes(Pair v) {
  constexpr std::int64_t kMagnitude = std::numeric_limits<std::int64_t>::max();  // all but the sign
  return std::bit_cast<Pair>(std::bit_cast<PairBits>(v) & kMagnitude);
}

// The robust plane of the first m offsets, with stack work space.
RobustPlane robust_plane_of(const Offsets& d, std::size_t m, const RobustFrameParams& params) {
  std::array<Vec3, kLocalNeighbors> offsets;
  for (std::size_t j = 0; j < m; ++j) offsets[j] = Vec3(d.x[j], d.y[j], d.z[j]);
  std::array<double, kLocalNeighbors + 1> weights;
  std::array<double, kLocalNeighbors + 1> scratch;
  return fit_robust_plane(std::span<const Vec3>(offsets.data(), m), params,
                          std::span<double>(weights.data(), m + 1),
                          std::span<double>(scratch.data(), m + 1));
}

struct Displacement {
  Vec3 value = Vec3::Zero();
  bool valid = false;
};

// What the step does, resolved once per call rather than per point.
enum class Kernel { Umbrella, IsotropicNormal, SharpPoint, SharpPlane, Continuous };

Kernel kernel_of(const FlowParams& params) {
  if (params.flow == Flow::Isotropic) return params.constrain_normal ? Kernel::IsotropicNormal : Kernel::Umbrella;
  if (params.cutoff == Cutoff::Continuous) return Kernel::Continuous;
  return params.cutoff_origin == CutoffOrigin::Plane ? Kernel::SharpPlane : Kernel::SharpPoint;
}

template <Kernel K>
Displacement fast_displacement(const Vec3& p, std::span<const Index> neighbors,
                               std::span<const Vec3> points, const FlowParams& params,
                               double lambda, Offsets& d) {
  Displacement out;
  const std::size_t m = neighbors.size();
  if (m == 0) return out;
  const double px = p.x(), py = p.y(), pz = p.z();
  for (std::size_t j = 0; j < m; ++j) {
    const double* q = points[neighbors[j]].data();
    d.x[j] = q[0] - px;
    d.y[j] = q[1] - py;
    d.z[j] = q[2] - pz;
  }
  d.x[m] = d.y[m] = d.z[m] = 0.0;
  const std::size_t padded = (m + 1) / 2 * 2;

  Pair sx{}, sy{}, sz{};
  Pair sxx{}, sxy{}, sxz{}, syy{}, syz{}, szz{};
  for (std::size_t j = 0; j < padded; j += 2) {
    const Pair x = load(d.x + j), y = load(d.y + j), z = load(d.z + j);
    sx += x;
    sy += y;
    sz += z;
    if constexpr (K != Kernel::Umbrella) {
      sxx += x * x;
      sxy += x * y;
      sxz += x * z;
      syy += y * y;
      syz += y * z;
      szz += z * z;
    }
  }
  const Vec3 sum(lane_sum(sx), lane_sum(sy), lane_sum(sz));
  const double inv_m = 1.0 / static_cast<double>(m);
  if constexpr (K == Kernel::Umbrella) {
    // The umbrella operator needs no frame.
    out.value = params.tau * (sum * inv_m);
    out.valid = true;
    return out;
  } else {
    // Covariance of {p} ∪ N about its barycentre p + mean (p itself is the offset 0).
    const double inv_count = 1.0 / static_cast<double>(m + 1);
    Vec3 mean = sum * inv_count;
    NormalEstimate estimate;
    if (params.normal_estimator == NormalEstimator::Robust) {
      // The robust plane (robust_frame.hpp) instead of the PCA plane: its normal and its
      // weighted barycentre; the cut-off below is the same.
      const RobustPlane plane = robust_plane_of(d, m, params.robust);
      estimate = NormalEstimate{plane.normal, plane.valid};
      mean = plane.mean;
    } else {
      Eigen::Matrix3d covariance;
      covariance(0, 0) = lane_sum(sxx) * inv_count - mean.x() * mean.x();
      covariance(0, 1) = lane_sum(sxy) * inv_count - mean.x() * mean.y();
      covariance(0, 2) = lane_sum(sxz) * inv_count - mean.x() * mean.z();
      covariance(1, 1) = lane_sum(syy) * inv_count - mean.y() * mean.y();
      covariance(1, 2) = lane_sum(syz) * inv_count - mean.y() * mean.z();
      covariance(2, 2) = lane_sum(szz) * inv_count - mean.z() * mean.z();
      covariance(1, 0) = covariance(0, 1);
      covariance(2, 0) = covariance(0, 2);
      covariance(2, 1) = covariance(1, 2);
      estimate = normal_from_covariance(covariance);
    }
    if (!estimate.valid || m < 2) return out;
    const Vec3& n = estimate.normal;
    Vec3 a = Vec3::Zero();
    if constexpr (K == Kernel::IsotropicNormal) {
      a = sum;
    } else if constexpr (K == Kernel::Continuous) {
      const Vec3 shift = params.cutoff_origin == CutoffOrigin::Plane ? Vec3(n.dot(mean) * n)
                                                                     : Vec3(Vec3::Zero());
      for (std::size_t j = 0; j < m; ++j) {
        const Vec3 dj(d.x[j], d.y[j], d.z[j]);
        const Vec3 e = dj - shift;
        const double len2 = e.squaredNorm();
        const double twice_nd = 2.0 * std::abs(n.dot(e));
        if (twice_nd < lambda * len2 || len2 == 0.0) {
          a += dj;
        } else {
          a += cutoff_weight(twice_nd / len2, lambda, Cutoff::Continuous) * dj;
        }
      }
    } else {
      // Sharp cut-off: |kappa| < lambda  <=>  2 |<n, e>| < lambda |e|^2 (no division), with e
      // the offset from the origin of the curvatures (CutoffOrigin): p itself, or its foot on
      // the PCA plane through the barycentre p + mean. The motion is still toward d.
      const Pair nx = splat(n.x()), ny = splat(n.y()), nz = splat(n.z());
      const Pair half_lambda = splat(0.5 * lambda);
      const Pair tiny = splat(std::numeric_limits<double>::denorm_min());
      const double height = K == Kernel::SharpPlane ? n.dot(mean) : 0.0;
      const Pair hx = splat(height * n.x()), hy = splat(height * n.y()), hz = splat(height * n.z());
      Pair ax{}, ay{}, az{};
      for (std::size_t j = 0; j < padded; j += 2) {
        const Pair x = load(d.x + j), y = load(d.y + j), z = load(d.z + j);
        Pair ex = x, ey = y, ez = z;
        if constexpr (K == Kernel::SharpPlane) {
          ex -= hx;
          ey -= hy;
          ez -= hz;
        }
        const Pair len2 = ex * ex + ey * ey + ez * ez;
        const Pair abs_nd = abs_lanes(nx * ex + ny * ey + nz * ez);
        // Kept: 2 |<n, e>| < lambda len2, or len2 == 0 (then <n, e> == 0 too); halving both
        // sides is exact. One comparison says both: adding the smallest subnormal changes no
        // normal threshold and makes a zero one positive (two masks or'ed together compile to
        // scalar code).
        const PairBits kept = abs_nd < half_lambda * len2 + tiny;
        ax += keep_if(x, kept);
        ay += keep_if(y, kept);
        az += keep_if(z, kept);
      }
      a = Vec3(lane_sum(ax), lane_sum(ay), lane_sum(az));
    }
    a *= inv_m;
    out.value = params.constrain_normal ? Vec3(params.tau * a.dot(n) * n) : Vec3(params.tau * a);
    out.valid = true;
    return out;
  }
}

template <Kernel K>
std::size_t step_rows(std::span<const Vec3> current, const Neighborhoods& neighborhoods,
                      std::span<const Index> rows, const FlowParams& params, double lambda,
                      bool gated, std::span<Vec3> next, std::size_t begin, std::size_t end) {
  // Feature gating: the point's curvature decides between the flow K (edges, corners) and
  // the isotropic Laplacian (smooth points), each from the same kernel as the ungated step.
  constexpr Kernel kIsotropic = K == Kernel::IsotropicNormal ? K : Kernel::Umbrella;
  const bool normal_only = params.constrain_normal;
  std::size_t degenerate = 0;
  Offsets offsets;
  for (std::size_t r = begin; r < end; ++r) {
    const Vec3& p = current[rows.empty() ? r : rows[r]];
    const auto nb = neighborhoods.of(r);
    Displacement d;
    if (gated || nb.size() > kLocalNeighbors) {
      const PointState s = evaluate_point(p, nb, current, params, lambda, gated);
      if (!s.valid || nb.size() > kLocalNeighbors) {
        d = {s.displacement, s.valid};
      } else if (s.feature == FeatureClass::Smooth) {
        d = normal_only ? fast_displacement<Kernel::IsotropicNormal>(p, nb, current, params, lambda, offsets)
                        : fast_displacement<kIsotropic>(p, nb, current, params, lambda, offsets);
      } else {
        d = fast_displacement<K>(p, nb, current, params, lambda, offsets);
      }
    } else {
      d = fast_displacement<K>(p, nb, current, params, lambda, offsets);
    }
    if (!d.valid) ++degenerate;
    next[r] = p + d.value;
  }
  return degenerate;
}

}  // namespace

StepStats euler_step(std::span<const Vec3> current, const Neighborhoods& neighborhoods,
                     std::span<const Index> rows, const FlowParams& params, double lambda,
                     std::span<Vec3> next) {
  const std::size_t n = neighborhoods.size();
  require(next.size() == n, "euler_step: next must hold one position per neighbourhood row");
  require(rows.empty() || rows.size() == n, "euler_step: rows must match the neighbourhoods");
  require(!rows.empty() || current.size() == n, "euler_step: one neighbourhood row per point");
  std::atomic<std::size_t> degenerate_total{0};
  const bool gated = params.feature_gated && params.features.mode != FeatureMode::None;
  const Kernel kernel = kernel_of(params);
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    const auto run = [&]<Kernel K>() {
      return step_rows<K>(current, neighborhoods, rows, params, lambda, gated, next, begin, end);
    };
    std::size_t degenerate = 0;
    switch (kernel) {
      case Kernel::Umbrella: degenerate = run.template operator()<Kernel::Umbrella>(); break;
      case Kernel::IsotropicNormal: degenerate = run.template operator()<Kernel::IsotropicNormal>(); break;
      case Kernel::SharpPoint: degenerate = run.template operator()<Kernel::SharpPoint>(); break;
      case Kernel::SharpPlane: degenerate = run.template operator()<Kernel::SharpPlane>(); break;
      case Kernel::Continuous: degenerate = run.template operator()<Kernel::Continuous>(); break;
    }
    degenerate_total.fetch_add(degenerate, std::memory_order_relaxed);
  }, 2048);
  return StepStats{degenerate_total.load()};
}

double auto_lambda(std::span<const Vec3> points, const Neighborhoods& neighborhoods, double factor,
                   std::span<const Index> row_of) {
  const std::size_t n = neighborhoods.size();
  if (n == 0) return 1.0;
  // An evenly strided sample of about 8192 points: the median of that many values is within
  // about 1% of the full one, and measuring it before every step then costs a few percent of
  // a step on large clouds. The sample depends only on n, so it is the same for any tiling.
  const std::size_t stride = std::max<std::size_t>(1, n / 8192);
  const std::size_t samples = (n + stride - 1) / stride;
  std::vector<double> medians(samples, -1.0);
  parallel_for(samples, [&](std::size_t begin, std::size_t end) {
    for (std::size_t s = begin; s < end; ++s) {
      const std::size_t i = row_of.empty() ? s * stride : row_of[s * stride];
      medians[s] = median_abs_curvature(points[i], neighborhoods.of(i), points);
    }
  }, 256);
  return lambda_from_medians(std::move(medians), factor);
}

double median_abs_curvature(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points) {
  const Frame f = compute_frame(p, neighbors, points);
  if (!f.valid) return -1.0;
  std::vector<double> kappas(neighbors.size());
  for (std::size_t j = 0; j < neighbors.size(); ++j)
    kappas[j] = std::abs(directional_curvature(f.normal, points[neighbors[j]] - p));
  const auto mid = kappas.begin() + static_cast<std::ptrdiff_t>(kappas.size() / 2);
  std::nth_element(kappas.begin(), mid, kappas.end());
  return *mid;
}

double lambda_from_medians(std::vector<double> medians, double factor) {
  std::erase_if(medians, [](double m) { return m < 0.0; });
  if (medians.empty()) return 1.0;
  auto mid = medians.begin() + static_cast<std::ptrdiff_t>(medians.size() / 2);
  std::nth_element(medians.begin(), mid, medians.end());
  // A flat cloud has median 0: no neighbour is then cut off (the flow is isotropic).
  const double m = *mid;
  return m > 0.0 ? factor * m : std::numeric_limits<double>::max();
}

double resolve_lambda(std::span<const Vec3> points, const Neighborhoods& neighborhoods,
                      const FlowParams& params) {
  params.validate();
  return params.lambda > 0.0 ? params.lambda
                             : auto_lambda(points, neighborhoods, params.lambda_auto_factor);
}

}  // namespace pointfair
