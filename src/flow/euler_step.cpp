#include "pointfair/flow/euler_step.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <cmath>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "frames/covariance_normal.hpp"
#include "frames/robust_plane_fit.hpp"

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

namespace {

// The noise gauge the robust plane's gate reads (RobustFrameParams::gate): the automatic
// lambda as measured, before lambda_auto_factor scales it into the cut-off's threshold; a fixed
// lambda as given.
double gate_lambda(const FlowParams& params, double lambda) {
  return params.lambda > 0.0 ? lambda : lambda / params.lambda_auto_factor;
}

// The robust frame, or the PCA frame where RobustFrameParams::gate keeps it.
Frame gated_robust_frame(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points,
                         const FlowParams& params, double lambda) {
  if (params.robust.gate > 0.0) {
    const Frame pca = compute_frame(p, neighbors, points);
    const double trace = pca.c0 + pca.c1 + pca.c2;
    if (pca.valid && !needs_robust_plane(pca.c0 / trace, trace, gate_lambda(params, lambda), params.robust.gate))
      return pca;
  }
  return compute_robust_frame(p, neighbors, points, params.robust);
}

}  // namespace

Frame point_frame(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points,
                  const FlowParams& params, double lambda) {
  if (neighbors.empty()) return Frame{};
  return params.normal_estimator == NormalEstimator::Robust ? gated_robust_frame(p, neighbors, points, params, lambda)
                                                            : compute_frame(p, neighbors, points);
}

PointState evaluate_point(const Vec3& p, std::span<const Index> neighbors,
                          std::span<const Vec3> points, const FlowParams& params, double lambda,
                          bool with_curvature) {
  PointState s;
  if (neighbors.empty()) return s;
  s.frame = point_frame(p, neighbors, points, params, lambda);
  const bool needs_frame = params.flow == Flow::Anisotropic || params.constrain_normal ||
                           params.feature_gated || with_curvature;
  if (needs_frame && !s.frame.valid) return s;
  s.valid = true;

  const bool gated = params.feature_gated && params.features.mode != FeatureMode::None;
  if (with_curvature || gated) {
    s.curvature = compute_curvature(p, s.frame, neighbors, points, params.weingarten);
    const double radius = params.features.threshold > 0.0 || params.features.scale == FeatureScale::Lambda
                              ? 0.0
                              : neighborhood_radius(p, neighbors, points);
    s.feature = classify_feature(s.curvature, params.features.mode, params.features.quotient,
                                 feature_threshold(params.features, lambda, radius));
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

// The step's hot path. One pass gathers the neighbour offsets into small local arrays, one per
// coordinate (structure of arrays), padded with zeros to a multiple of four; the sums of the
// covariance and of the cut-off then run over four neighbours at a time (GCC / Clang vector
// types: one AVX2 register in the AVX2 kernel, two SSE2 registers in the plain one), one
// accumulator a quantity (more would spill). Lane l always sums neighbours l, l + 4,
// l + 8, ... in that order and the lanes are added as (0 + 2) + (1 + 3) in both kernels, and
// neither kernel fuses a multiply into an add (the AVX2 one is compiled for "avx2" alone, not
// "fma"), so both give the same bits, which depend on nothing but the inputs. A zero offset
// adds nothing to any sum, so the padding changes no result. The cut-off is a mask, not a
// branch. Same formulas as evaluate_point (which the tests hold it against, with the plain
// reference in tests/support); evaluate_point classifies the points under feature gating and
// moves those with more than kLocalNeighbors neighbours. That bound was 64: a chosen k of 80
// then stepped 3.5 times slower than one of 48 (10 steps on a 200K-point fandisk, 1.60 s
// against 0.35 s; with 128, 0.46 s), and the kernels' work space for 128 is 33 KB of stack.
//
// The arrays hold the offsets negated, b_j = p - p_j = -d_j: the subtraction then reads p_j
// straight from memory (one instruction, x and y together). Negation is exact and commutes
// with rounding, so every sum below is the exact negative of the sum of the d_j, every
// product and square is unchanged, and the covariance, the normal and the cut-off decisions
// are those of the d_j to the bit; the motion is negated back at the end.
constexpr std::size_t kLocalNeighbors = 128;
constexpr std::size_t kLanes = 4;

// Four lanes of doubles, two ways. Wide: one AVX register (the AVX2 kernel). Split: two SSE2
// registers, lanes 0 and 1 in lo, 2 and 3 in hi (the plain kernel). The loops run over lane
// groups G: the one Wide group, or each Pair half of a Split in turn (two passes over the
// offsets, lanes 0-1 then lanes 2-3: nine accumulators of both halves at once would not fit
// in the 16 SSE registers, and GCC's own lowering of a 32-byte vector without AVX goes
// through memory). Each lane sees the same operations on the same neighbours in the same
// order either way, so both kernels give the same bits.
using Wide = double __attribute__((vector_size(kLanes * sizeof(double))));
using WideBits = std::int64_t __attribute__((vector_size(kLanes * sizeof(double))));
using Pair = double __attribute__((vector_size(2 * sizeof(double))));
using PairBits = std::int64_t __attribute__((vector_size(2 * sizeof(double))));
struct Split {
  Pair lo, hi;
};

// Every function below that takes or returns a Wide is inlined into the AVX2 instantiation of
// step_rows, so no Wide crosses a call and the calling convention GCC warns about (32-byte
// vectors without AVX) is never used. (GCC reports it at the end of the file, so it stays off
// for the whole file.)
#define POINTFAIR_INLINE [[gnu::always_inline]] inline
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wpsabi"
#endif

struct Offsets {
  // Up to three more slots for the padding zeros.
  alignas(sizeof(Wide)) double x[kLocalNeighbors + kLanes];
  alignas(sizeof(Wide)) double y[kLocalNeighbors + kLanes];
  alignas(sizeof(Wide)) double z[kLocalNeighbors + kLanes];
};

template <class G>
POINTFAIR_INLINE G load(const double* from) {
  G v;
  std::memcpy(&v, from, sizeof v);
  return v;
}
template <class G>
POINTFAIR_INLINE G splat(double x) {
  if constexpr (std::is_same_v<G, Pair>) {
    return Pair{x, x};
  } else {
    return Wide{x, x, x, x};
  }
}

// The lanes of v where a < b, zero elsewhere (a mask, no branch).
template <class G>
POINTFAIR_INLINE G keep_if_less(const G& v, const G& a, const G& b) {
  using Bits = std::conditional_t<std::is_same_v<G, Pair>, PairBits, WideBits>;
  return std::bit_cast<G>(std::bit_cast<Bits>(v) & (a < b));
}
template <class G>
POINTFAIR_INLINE G abs_lanes(const G& v) {
  using Bits = std::conditional_t<std::is_same_v<G, Pair>, PairBits, WideBits>;
  constexpr std::int64_t kMagnitude = std::numeric_limits<std::int64_t>::max();  // all but the sign
  return std::bit_cast<G>(std::bit_cast<Bits>(v) & kMagnitude);
}

// The sums of the four lanes of a, b, c and d, each as (0 + 2) + (1 + 3): a few shuffles for
// all four rather than a chain of extractions each.
struct LaneSums {
  double a, b, c, d;
};
POINTFAIR_INLINE LaneSums lane_sums(const Wide& a, const Wide& b, const Wide& c, const Wide& d) {
  const Wide ab = __builtin_shufflevector(a, b, 0, 1, 4, 5) + __builtin_shufflevector(a, b, 2, 3, 6, 7);
  const Wide cd = __builtin_shufflevector(c, d, 0, 1, 4, 5) + __builtin_shufflevector(c, d, 2, 3, 6, 7);
  const Wide acbd = __builtin_shufflevector(ab, cd, 0, 4, 2, 6) + __builtin_shufflevector(ab, cd, 1, 5, 3, 7);
  return {acbd[0], acbd[2], acbd[1], acbd[3]};
}
POINTFAIR_INLINE LaneSums lane_sums(const Split& a, const Split& b, const Split& c, const Split& d) {
  const Pair pa = a.lo + a.hi, pb = b.lo + b.hi, pc = c.lo + c.hi, pd = d.lo + d.hi;
  const Pair ac = __builtin_shufflevector(pa, pc, 0, 2) + __builtin_shufflevector(pa, pc, 1, 3);
  const Pair bd = __builtin_shufflevector(pb, pd, 0, 2) + __builtin_shufflevector(pb, pd, 1, 3);
  return {ac[0], bd[0], ac[1], bd[1]};
}

// Lane group G's share of the sums of the offsets and of their products, over the lanes that
// start at `first` (0, or 2 for the upper Pair), four neighbours a step.
template <class G>
struct MomentSums {
  G x{}, y{}, z{}, xx{}, xy{}, xz{}, yy{}, yz{}, zz{};
};
template <bool kProducts, class G>
POINTFAIR_INLINE MomentSums<G> moment_pass(const Offsets& d, std::size_t padded, std::size_t first) {
  MomentSums<G> s;
  for (std::size_t j = first; j < padded; j += kLanes) {
    const G x = load<G>(d.x + j), y = load<G>(d.y + j), z = load<G>(d.z + j);
    s.x += x;
    s.y += y;
    s.z += z;
    if constexpr (kProducts) {
      s.xx += x * x;
      s.xy += x * y;
      s.xz += x * z;
      s.yy += y * y;
      s.yz += y * z;
      s.zz += z * z;
    }
  }
  return s;
}
// The same for a lane type Q (Wide, or Split: both halves).
template <bool kProducts, class Q>
POINTFAIR_INLINE MomentSums<Q> moment_sums(const Offsets& d, std::size_t padded) {
  if constexpr (std::is_same_v<Q, Wide>) {
    return moment_pass<kProducts, Wide>(d, padded, 0);
  } else {
    const MomentSums<Pair> lo = moment_pass<kProducts, Pair>(d, padded, 0);
    const MomentSums<Pair> hi = moment_pass<kProducts, Pair>(d, padded, 2);
    return {{lo.x, hi.x}, {lo.y, hi.y}, {lo.z, hi.z}, {lo.xx, hi.xx}, {lo.xy, hi.xy},
            {lo.xz, hi.xz}, {lo.yy, hi.yy}, {lo.yz, hi.yz}, {lo.zz, hi.zz}};
  }
}

// The sharp cut-off's sums of the kept offsets: |kappa| < lambda  <=>  2 |<n, e>| < lambda
// |e|^2 (no division), with e the offset from the origin of the curvatures (CutoffOrigin): p
// itself (height 0), or its foot on the PCA plane, `height` along n. The motion is still
// toward the offset itself.
template <class G>
struct KeptSums {
  G x{}, y{}, z{};
};
template <bool kPlane, class G>
POINTFAIR_INLINE KeptSums<G> kept_pass(const Offsets& d, std::size_t padded, std::size_t first,
                                       const Vec3& n, double lambda, double height) {
  const G nx = splat<G>(n.x()), ny = splat<G>(n.y()), nz = splat<G>(n.z());
  const G half_lambda = splat<G>(0.5 * lambda);
  const G tiny = splat<G>(std::numeric_limits<double>::denorm_min());
  const G hx = splat<G>(height * n.x()), hy = splat<G>(height * n.y()), hz = splat<G>(height * n.z());
  KeptSums<G> s;
  for (std::size_t j = first; j < padded; j += kLanes) {
    const G x = load<G>(d.x + j), y = load<G>(d.y + j), z = load<G>(d.z + j);
    G ex = x, ey = y, ez = z;
    if constexpr (kPlane) {
      ex -= hx;
      ey -= hy;
      ez -= hz;
    }
    const G len2 = ex * ex + ey * ey + ez * ez;
    const G abs_nd = abs_lanes(nx * ex + ny * ey + nz * ez);
    // Kept: 2 |<n, e>| < lambda len2, or len2 == 0 (then <n, e> == 0 too); halving both
    // sides is exact. One comparison says both: adding the smallest subnormal changes no
    // normal threshold and makes a zero one positive (two masks or'ed together compile to
    // scalar code).
    const G threshold = half_lambda * len2 + tiny;
    s.x += keep_if_less(x, abs_nd, threshold);
    s.y += keep_if_less(y, abs_nd, threshold);
    s.z += keep_if_less(z, abs_nd, threshold);
  }
  return s;
}
template <bool kPlane, class Q>
POINTFAIR_INLINE KeptSums<Q> kept_sums(const Offsets& d, std::size_t padded, const Vec3& n,
                                       double lambda, double height) {
  if constexpr (std::is_same_v<Q, Wide>) {
    return kept_pass<kPlane, Wide>(d, padded, 0, n, lambda, height);
  } else {
    const KeptSums<Pair> lo = kept_pass<kPlane, Pair>(d, padded, 0, n, lambda, height);
    const KeptSums<Pair> hi = kept_pass<kPlane, Pair>(d, padded, 2, n, lambda, height);
    return {{lo.x, hi.x}, {lo.y, hi.y}, {lo.z, hi.z}};
  }
}

// The robust plane of the first m offsets, with stack work space.
RobustPlane robust_plane_of(const Offsets& d, std::size_t m, const RobustFrameParams& params) {
  std::array<Vec3, kLocalNeighbors> offsets;
  for (std::size_t j = 0; j < m; ++j) offsets[j] = -Vec3(d.x[j], d.y[j], d.z[j]);
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

// What the cut-off needs of a point once its offsets are gathered: their (negated) sum, the
// count, and (but for the umbrella operator) the covariance about the barycentre p - mean.
struct Prepared {
  Vec3 sum = Vec3::Zero();
  Vec3 mean = Vec3::Zero();
  std::size_t m = 0;
  std::size_t padded = 0;
  detail::SymmetricCovariance covariance;
  /// The covariance's trace before symmetric_covariance brings it near 1 (which only a
  /// trace outside [2^-200, 2^200] needs): the robust plane's gate reads it.
  double trace = 0.0;
};

// Gathers the m > 0 neighbour offsets of p into d and sums them into s.
template <Kernel K, class Q>
POINTFAIR_INLINE void prepare(const Vec3& p, std::span<const Index> neighbors,
                              std::span<const Vec3> points, Offsets& d, Prepared& s) {
  const std::size_t m = neighbors.size();
  s.m = m;
  const Pair pxy{p.x(), p.y()};
  const double pz = p.z();
  for (std::size_t j = 0; j < m; ++j) {
    const double* q = points[neighbors[j]].data();
    Pair qxy;
    std::memcpy(&qxy, q, sizeof qxy);
    const Pair bxy = pxy - qxy;
    d.x[j] = bxy[0];
    d.y[j] = bxy[1];
    d.z[j] = pz - q[2];
  }
  s.padded = (m + kLanes - 1) / kLanes * kLanes;
  for (std::size_t j = m; j < s.padded; ++j) d.x[j] = d.y[j] = d.z[j] = 0.0;

  const MomentSums<Q> moments = moment_sums<K != Kernel::Umbrella, Q>(d, s.padded);
  const LaneSums sums = lane_sums(moments.x, moments.y, moments.z, Q{});
  // The negated sum of the d_j (see above).
  s.sum = Vec3(sums.a, sums.b, sums.c);
  if constexpr (K != Kernel::Umbrella) {
    // Covariance of {p} ∪ N about its barycentre p - mean (p itself is the offset 0).
    const double inv_count = 1.0 / static_cast<double>(m + 1);
    const Vec3 mean = s.sum * inv_count;
    s.mean = mean;
    const LaneSums s1 = lane_sums(moments.xx, moments.xy, moments.xz, moments.yy);
    const LaneSums s2 = lane_sums(moments.yz, moments.zz, Q{}, Q{});
    const double a00 = s1.a * inv_count - mean.x() * mean.x();
    const double a11 = s1.d * inv_count - mean.y() * mean.y();
    const double a22 = s2.b * inv_count - mean.z() * mean.z();
    s.covariance = detail::symmetric_covariance(a00, s1.b * inv_count - mean.x() * mean.y(),
                                                s1.c * inv_count - mean.x() * mean.z(), a11,
                                                s2.a * inv_count - mean.y() * mean.z(), a22);
    s.trace = a00 + a11 + a22;
  }
}

// The motion of a prepared point with the plane (normal, and the barycentre p - mean).
template <Kernel K, class Q>
POINTFAIR_INLINE Displacement finish(const Prepared& s, const Vec3& mean,
                                     const NormalEstimate& estimate, const FlowParams& params,
                                     double lambda, const Offsets& d) {
  Displacement out;
  const std::size_t m = s.m;
  if (!estimate.valid || m < 2) return out;
  const Vec3& n = estimate.normal;
  Vec3 a = Vec3::Zero();
  if constexpr (K == Kernel::IsotropicNormal) {
    a = s.sum;
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
    // Sharp cut-off (kept_pass), from the foot on the PCA plane through the barycentre
    // p - mean (negated, as the offsets) or from p.
    const double height = K == Kernel::SharpPlane ? n.dot(mean) : 0.0;
    const KeptSums<Q> kept = kept_sums<K == Kernel::SharpPlane, Q>(d, s.padded, n, lambda, height);
    const LaneSums sa = lane_sums(kept.x, kept.y, kept.z, Q{});
    a = Vec3(sa.a, sa.b, sa.c);
  }
  // Back from the negated offsets to the d_j.
  a = -a * (1.0 / static_cast<double>(m));
  out.value = params.constrain_normal ? Vec3(params.tau * a.dot(n) * n) : Vec3(params.tau * a);
  out.valid = true;
  return out;
}

// The motion of one point.
template <Kernel K, class Q>
POINTFAIR_INLINE Displacement fast_displacement(const Vec3& p, std::span<const Index> neighbors,
                                                std::span<const Vec3> points,
                                                const FlowParams& params, double lambda,
                                                Offsets& d) {
  if (neighbors.empty()) return {};
  Prepared s;
  prepare<K, Q>(p, neighbors, points, d, s);
  if constexpr (K == Kernel::Umbrella) {
    // The umbrella operator needs no frame.
    return {params.tau * (-s.sum * (1.0 / static_cast<double>(s.m))), true};
  } else {
    const detail::SymmetricCovariance& c = s.covariance;
    if (params.normal_estimator == NormalEstimator::Robust) {
      // The PCA plane where the gate keeps it (RobustFrameParams::gate), else the robust plane
      // (robust_frame.hpp): its normal and its weighted barycentre; the cut-off is the same.
      if (params.robust.gate > 0.0) {
        double c0 = 0.0;
        const detail::SymmetricCovariance* one = &c;
        detail::smallest_eigenvalues<1>(&one, 1, &c0);
        if (!needs_robust_plane(c0 / c.tr, s.trace, gate_lambda(params, lambda), params.robust.gate))
          return finish<K, Q>(s, s.mean, detail::normal_from_smallest_eigenvalue(c, c0), params, lambda, d);
      }
      const RobustPlane plane = robust_plane_of(d, s.m, params.robust);
      return finish<K, Q>(s, -plane.mean, NormalEstimate{plane.normal, plane.valid}, params,
                          lambda, d);
    }
    return finish<K, Q>(s, s.mean, detail::covariance_normal(c.a00, c.a01, c.a02, c.a11, c.a12, c.a22),
                        params, lambda, d);
  }
}

template <Kernel K, class Q>
POINTFAIR_INLINE std::size_t step_rows(std::span<const Vec3> current,
                                       NeighborhoodsView neighborhoods,
                                       std::span<const Index> rows, const FlowParams& params,
                                       double lambda, bool gated, std::span<Vec3> next,
                                       std::size_t begin, std::size_t end) {
  // Feature gating: the point's curvature decides between the flow K (edges, corners) and
  // the isotropic Laplacian (smooth points), each from the same kernel as the ungated step.
  constexpr Kernel kIsotropic = K == Kernel::IsotropicNormal ? K : Kernel::Umbrella;
  const bool normal_only = params.constrain_normal;
  std::size_t degenerate = 0;
  const bool batched = K != Kernel::Umbrella && !gated;
  if (!batched) {
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
          d = normal_only ? fast_displacement<Kernel::IsotropicNormal, Q>(p, nb, current, params, lambda, offsets)
                          : fast_displacement<kIsotropic, Q>(p, nb, current, params, lambda, offsets);
        } else {
          d = fast_displacement<K, Q>(p, nb, current, params, lambda, offsets);
        }
      } else {
        d = fast_displacement<K, Q>(p, nb, current, params, lambda, offsets);
      }
      if (!d.valid) ++degenerate;
      next[r] = p + d.value;
    }
    return degenerate;
  }
  // No gating: kBatch points at a time, their normals' iterations interleaved
  // (detail::smallest_eigenvalues; for the robust plane, detail::fit_robust_planes). Each
  // point's result is the one it gets alone, to the bit.
  constexpr std::size_t kBatch = 4;
  const bool robust = params.normal_estimator == NormalEstimator::Robust;
  // The robust plane's gate (RobustFrameParams::gate) and the noise gauge it reads.
  const bool gate = robust && params.robust.gate > 0.0;
  const double gauge = gate_lambda(params, lambda);
  Offsets offsets[kBatch];
  Prepared prepared[kBatch];
  const detail::SymmetricCovariance* covariances[kBatch];
  std::size_t batch_rows[kBatch];
  // The robust fit's work space: the offsets as vectors (d_j, not negated), weights, scratch.
  std::array<std::array<Vec3, kLocalNeighbors>, kBatch> robust_offsets;
  std::array<std::array<double, kLocalNeighbors + 1>, kBatch> robust_weights, robust_scratch;
  for (std::size_t r = begin; r < end;) {
    std::size_t count = 0;
    for (; r < end && count < kBatch; ++r) {
      const Vec3& p = current[rows.empty() ? r : rows[r]];
      const auto nb = neighborhoods.of(r);
      if (nb.empty() || nb.size() > kLocalNeighbors) {
        Displacement d;
        if (!nb.empty()) {
          const PointState s = evaluate_point(p, nb, current, params, lambda, false);
          d = {s.displacement, s.valid};
        }
        if (!d.valid) ++degenerate;
        next[r] = p + d.value;
        continue;
      }
      prepare<K, Q>(p, nb, current, offsets[count], prepared[count]);
      covariances[count] = &prepared[count].covariance;
      batch_rows[count] = r;
      ++count;
    }
    if (robust) {
      // With a gate, the points whose PCA plane it keeps move at once; the others (lanes
      // lane_of[0, fits)) get the robust plane, batched as before.
      double c0[kBatch];
      if (gate) detail::smallest_eigenvalues<kBatch>(covariances, count, c0);
      std::span<const Vec3> lane_offsets[kBatch];
      std::span<double> lane_weights[kBatch], lane_scratch[kBatch];
      std::size_t lane_of[kBatch];
      std::size_t fits = 0;
      for (std::size_t i = 0; i < count; ++i) {
        const Prepared& s = prepared[i];
        if (gate && !needs_robust_plane(c0[i] / s.covariance.tr, s.trace, gauge, params.robust.gate)) {
          const std::size_t row = batch_rows[i];
          const Vec3& p = current[rows.empty() ? row : rows[row]];
          const NormalEstimate estimate = detail::normal_from_smallest_eigenvalue(s.covariance, c0[i]);
          const Displacement d = finish<K, Q>(s, s.mean, estimate, params, lambda, offsets[i]);
          if (!d.valid) ++degenerate;
          next[row] = p + d.value;
          continue;
        }
        const std::size_t m = s.m;
        const Offsets& d = offsets[i];
        for (std::size_t j = 0; j < m; ++j) robust_offsets[fits][j] = -Vec3(d.x[j], d.y[j], d.z[j]);
        lane_offsets[fits] = std::span<const Vec3>(robust_offsets[fits].data(), m);
        lane_weights[fits] = std::span<double>(robust_weights[fits].data(), m + 1);
        lane_scratch[fits] = std::span<double>(robust_scratch[fits].data(), m + 1);
        lane_of[fits++] = i;
      }
      RobustPlane planes[kBatch];
      detail::fit_robust_planes<kBatch>(lane_offsets, fits, params.robust, lane_weights,
                                        lane_scratch, planes);
      for (std::size_t f = 0; f < fits; ++f) {
        const std::size_t i = lane_of[f];
        const std::size_t row = batch_rows[i];
        const Vec3& p = current[rows.empty() ? row : rows[row]];
        const Displacement d = finish<K, Q>(prepared[i], -planes[f].mean,
                                            NormalEstimate{planes[f].normal, planes[f].valid},
                                            params, lambda, offsets[i]);
        if (!d.valid) ++degenerate;
        next[row] = p + d.value;
      }
      continue;
    }
    double c0[kBatch];
    detail::smallest_eigenvalues<kBatch>(covariances, count, c0);
    for (std::size_t i = 0; i < count; ++i) {
      const std::size_t row = batch_rows[i];
      const Vec3& p = current[rows.empty() ? row : rows[row]];
      const NormalEstimate estimate = detail::normal_from_smallest_eigenvalue(prepared[i].covariance, c0[i]);
      const Displacement d = finish<K, Q>(prepared[i], prepared[i].mean, estimate, params, lambda, offsets[i]);
      if (!d.valid) ++degenerate;
      next[row] = p + d.value;
    }
  }
  return degenerate;
}

// The two instantiations of the row loop: the same source, compiled for the build's baseline
// and for AVX2. Only code inlined into the AVX2 one uses AVX2; what it calls (the slow path,
// the normal's fallback) is the baseline's.
template <Kernel K>
std::size_t step_rows_plain(std::span<const Vec3> current, NeighborhoodsView neighborhoods,
                            std::span<const Index> rows, const FlowParams& params, double lambda,
                            bool gated, std::span<Vec3> next, std::size_t begin, std::size_t end) {
  return step_rows<K, Split>(current, neighborhoods, rows, params, lambda, gated, next, begin, end);
}

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define POINTFAIR_HAS_AVX2_KERNEL 1
template <Kernel K>
__attribute__((target("avx2"))) std::size_t step_rows_avx2(
    std::span<const Vec3> current, NeighborhoodsView neighborhoods,
    std::span<const Index> rows, const FlowParams& params, double lambda, bool gated,
    std::span<Vec3> next, std::size_t begin, std::size_t end) {
  return step_rows<K, Wide>(current, neighborhoods, rows, params, lambda, gated, next, begin, end);
}
#else
#define POINTFAIR_HAS_AVX2_KERNEL 0
#endif

bool cpu_has_avx2() {
#if POINTFAIR_HAS_AVX2_KERNEL
  // libgcc's and compiler-rt's answer also checks that the OS saves the 256-bit registers.
  __builtin_cpu_init();
  return __builtin_cpu_supports("avx2");
#else
  return false;
#endif
}

bool avx2_disabled_by_environment() {
  const char* value = std::getenv("POINTFAIR_NO_AVX2");
  return value != nullptr && value[0] != '\0' && std::string_view(value) != "0";
}

}  // namespace

bool step_kernel_available(StepKernel kernel) {
  static const bool has_avx2 = cpu_has_avx2();
  return kernel == StepKernel::Plain || has_avx2;
}

StepKernel default_step_kernel() {
  static const StepKernel kernel = !avx2_disabled_by_environment() && step_kernel_available(StepKernel::Avx2)
                                       ? StepKernel::Avx2
                                       : StepKernel::Plain;
  return kernel;
}

StepStats euler_step(std::span<const Vec3> current, NeighborhoodsView neighborhoods,
                     std::span<const Index> rows, const FlowParams& params, double lambda,
                     std::span<Vec3> next) {
  return euler_step(current, neighborhoods, rows, params, lambda, next, default_step_kernel());
}

StepStats euler_step(std::span<const Vec3> current, NeighborhoodsView neighborhoods,
                     std::span<const Index> rows, const FlowParams& params, double lambda,
                     std::span<Vec3> next, StepKernel simd) {
  const std::size_t n = neighborhoods.size();
  require(next.size() == n, "euler_step: next must hold one position per neighbourhood row");
  require(rows.empty() || rows.size() == n, "euler_step: rows must match the neighbourhoods");
  require(!rows.empty() || current.size() == n, "euler_step: one neighbourhood row per point");
  require(step_kernel_available(simd), "euler_step: the AVX2 kernel is not available here");
  std::atomic<std::size_t> degenerate_total{0};
  const bool gated = params.feature_gated && params.features.mode != FeatureMode::None;
  const Kernel kernel = kernel_of(params);
  const bool avx2 = simd == StepKernel::Avx2;
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    const auto run = [&]<Kernel K>() {
#if POINTFAIR_HAS_AVX2_KERNEL
      if (avx2)
        return step_rows_avx2<K>(current, neighborhoods, rows, params, lambda, gated, next, begin, end);
#endif
      return step_rows_plain<K>(current, neighborhoods, rows, params, lambda, gated, next, begin, end);
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
