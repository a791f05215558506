#include "pointfair/finish/quadric_projection.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <numeric>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Cholesky>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/flow/euler_step.hpp"
#include "pointfair/neighbors/knn_grid.hpp"
#include "pointfair/neighbors/spatial_order.hpp"
#include "common/select_kth.hpp"
#include "frames/robust_plane_fit.hpp"

namespace pointfair {
namespace {

// The monomials u^(d-i) v^i of degree d = 0 .. Degree in that order: for Degree 2 the height
// field h(u, v) = c0 + c1 u + c2 v + c3 u^2 + c4 u v + c5 v^2.
template <int Degree>
constexpr int kTerms = (Degree + 1) * (Degree + 2) / 2;

// The terms of degree d come from those of degree d - 1: each times u, then the last one times
// v as well. Written out as named products (the same products in the same order as that
// recursion): built in an array, the compiler stored the terms and loaded them back in pairs,
// and each such load waited on two stores (a sixth of the fits' time).
template <int Degree>
[[gnu::always_inline]] inline void write_monomials(double u, double v, double* m) {
  static_assert(Degree == 2 || Degree == 3);
  const double uu = u * u, vu = v * u, vv = v * v;
  m[0] = 1.0;
  m[1] = u;  // 1 u and 1 v: exact
  m[2] = v;
  m[3] = uu;
  m[4] = vu;
  m[5] = vv;
  if constexpr (Degree == 3) {
    m[6] = uu * u;
    m[7] = vu * u;
    m[8] = vv * u;
    m[9] = vv * v;
  }
}

template <int Degree>
Eigen::Matrix<double, kTerms<Degree>, 1> monomials(double u, double v) {
  Eigen::Matrix<double, kTerms<Degree>, 1> m;
  write_monomials<Degree>(u, v, m.data());
  return m;
}

// Each row of the design matrix padded to a multiple of four doubles, so that the loops over a
// row's terms run in whole vectors.
template <int Degree>
constexpr int kStride = (kTerms<Degree> + 3) / 4 * 4;

struct Scratch {
  std::vector<Vec3> offsets;
  std::vector<double> u, v, h, weights, start_weights, plane_scratch, residuals, design;
};

double reach_of(const Scratch& s, std::size_t count) {
  double reach = 0.0;
  for (std::size_t j = 0; j < count; ++j) reach = std::max(reach, s.u[j] * s.u[j] + s.v[j] * s.v[j]);
  return std::sqrt(reach);
}

// Four doubles in one vector register (AVX2), or two of SSE2 in the baseline's build.
using Lane4 = double __attribute__((vector_size(32)));

// The columns of row p of the lower triangle that are summed: 0..p rounded up to a whole
// vector of four (the padding is summed, unread).
template <int Stride>
constexpr int gram_columns(int p) {
  return std::min(Stride, (p / 4 + 1) * 4);
}

// Rows [R0, R1) of normal_equations' lower triangle (and with Rhs its right-hand side), each
// entry summed over the rows of `design` with positive weight in the rows' order, every
// product (w a_p) a_q as a plain loop would form it: the same bits. The sums stay in vector
// registers across the rows of `design` (the rows of one call and the right-hand side take 15
// of AVX2's 16), where a loop over the whole triangle would load and store each of them at
// every row. Returns how many rows of `design` have a positive weight.
template <int R0, int R1, int Stride, bool Rhs>
[[gnu::always_inline]] inline std::size_t gram_rows(const double* design, const double* h, const double* weights,
                                             std::size_t count, double* gram, double* rhs) {
  constexpr int kVectors = Stride / 4;
  Lane4 sums[R1 - R0][kVectors] = {};
  Lane4 rhs_sums[kVectors] = {};
  std::size_t kept = 0;
  for (std::size_t j = 0; j < count; ++j) {
    const double w = weights[j];
    if (w <= 0.0) continue;
    ++kept;
    const double* a = design + j * Stride;
    Lane4 row[kVectors];
#pragma GCC unroll 4
    for (int c = 0; c < kVectors; ++c) std::memcpy(&row[c], a + 4 * c, sizeof(Lane4));
    if constexpr (Rhs) {
      const double wh = w * h[j];
      const Lane4 b = {wh, wh, wh, wh};
#pragma GCC unroll 4
      for (int c = 0; c < kVectors; ++c) rhs_sums[c] += b * row[c];
    }
#pragma GCC unroll 16
    for (int p = R0; p < R1; ++p) {
      const double wa = w * a[p];
      const Lane4 b = {wa, wa, wa, wa};
      for (int c = 0; c < gram_columns<Stride>(p) / 4; ++c) sums[p - R0][c] += b * row[c];
    }
  }
  for (int p = R0; p < R1; ++p)
    for (int c = 0; c < gram_columns<Stride>(p) / 4; ++c) std::memcpy(gram + p * Stride + 4 * c, &sums[p - R0][c], sizeof(Lane4));
  if constexpr (Rhs)
    for (int c = 0; c < kVectors; ++c) std::memcpy(rhs + 4 * c, &rhs_sums[c], sizeof(Lane4));
  return kept;
}

// The lower triangle of sum_j w_j a_j a_j^T into `gram` (kTerms rows of kStride, row p holding
// columns 0..p and padding beyond) and sum_j w_j h_j a_j into `rhs`, over the rows a_j of
// `design` whose weight is positive; returns how many those are. Every entry is summed in the
// rows' order (gram_rows), whatever width the vectors are.
template <int Degree>
[[gnu::always_inline]] inline std::size_t weighted_normal_equations(const double* design, const double* h, const double* weights,
                                      std::size_t count, double* gram, double* rhs) {
  constexpr int terms = kTerms<Degree>;
  constexpr int stride = kStride<Degree>;
  std::fill(gram, gram + terms * stride, 0.0);
  if constexpr (terms <= 8) {
    return gram_rows<0, terms, stride, true>(design, h, weights, count, gram, rhs);
  } else {
    const std::size_t kept = gram_rows<0, 8, stride, true>(design, h, weights, count, gram, rhs);
    gram_rows<8, terms, stride, false>(design, h, weights, count, gram, rhs);
    return kept;
  }
}

// The polynomial fitted to the first `count` points of (s.u, s.v, s.h), weighted by
// s.weights (reweighted in place): its height at u = v = 0, its second derivatives
// (h_uu, h_uv, h_vv) when `second` is not null, and the robust scale of its residuals (1.4826
// times their median) when `scale` is not null; false when the points do not determine it.
// With `coefficients`, also the polynomial's coefficients (tangent coordinates in units of the
// fit's reach, reach_of) into it.
template <int Degree>
[[gnu::always_inline]] inline bool fit_height(const QuadricProjectionParams& params, std::size_t count, Scratch& s, double& height,
                double* second = nullptr, double* scale = nullptr, double* coefficients = nullptr) {
  constexpr int terms = kTerms<Degree>;
  constexpr int stride = kStride<Degree>;
  using Vec = Eigen::Matrix<double, terms, 1>;
  using Mat = Eigen::Matrix<double, terms, terms>;
  const double reach = reach_of(s, count);
  if (!(reach > 0.0)) return false;
  // Tangent coordinates in units of the fit's reach keep the normal equations well
  // conditioned; the constant term, the height above p, is unchanged by that.
  const double inv_reach = 1.0 / reach;
  // Each row written whole, its padding zeroed here (the vector is not cleared first: that
  // cost as much as the rows themselves).
  if (s.design.size() < count * stride) s.design.resize(count * stride);
  for (std::size_t j = 0; j < count; ++j) {
    double* row = s.design.data() + j * stride;
    write_monomials<Degree>(s.u[j] * inv_reach, s.v[j] * inv_reach, row);
    std::fill(row + terms, row + stride, 0.0);
  }
  // h minus the fit at row j.
  const auto residual = [&](std::size_t j, const Vec& c) {
    const double* a = s.design.data() + j * stride;
    double fitted = 0.0;
    for (int t = 0; t < terms; ++t) fitted += a[t] * c[t];
    return s.h[j] - fitted;
  };
  Vec c = Vec::Zero();
  bool fitted = false;
  alignas(32) double gram[terms * stride];
  alignas(32) double rhs_terms[stride];
  for (int pass = 0; pass <= params.iterations; ++pass) {
    const std::size_t kept =
        weighted_normal_equations<Degree>(s.design.data(), s.h.data(), s.weights.data(), count, gram, rhs_terms);
    if (kept < static_cast<std::size_t>(terms)) break;
    Mat normal_matrix;
    for (int p = 0; p < terms; ++p)
      for (int q = 0; q <= p; ++q) normal_matrix(p, q) = normal_matrix(q, p) = gram[p * stride + q];
    const Vec rhs = Eigen::Map<const Vec>(rhs_terms);
    const Eigen::LDLT<Mat> ldlt(normal_matrix);
    const Vec d = ldlt.vectorD().cwiseAbs();
    if (ldlt.info() != Eigen::Success || !(d.minCoeff() > 1e-9 * d.maxCoeff())) break;
    c = ldlt.solve(rhs);
    fitted = true;
    if (pass == params.iterations) break;
    for (std::size_t j = 0; j < count; ++j) s.residuals[j] = std::abs(residual(j, c));
    const std::span<double> w(s.weights.data(), count), scratch(s.plane_scratch.data(), count);
    detail::biweights(std::span<const double>(s.residuals.data(), count), params.inlier_bound, 1e-12 * reach, w,
                      scratch);
  }
  if (!fitted || !std::isfinite(c[0])) return false;
  height = c[0];
  if (coefficients != nullptr) std::copy(c.data(), c.data() + terms, coefficients);
  if (scale != nullptr) {
    for (std::size_t j = 0; j < count; ++j) s.residuals[j] = std::abs(residual(j, c));
    *scale = 1.4826 * detail::select_kth(std::span<const double>(s.residuals.data(), count), count / 2,
                                         std::span<double>(s.plane_scratch.data(), count));
  }
  if (second != nullptr) {
    const double per_reach2 = inv_reach * inv_reach;
    second[0] = 2.0 * c[3] * per_reach2;
    second[1] = c[4] * per_reach2;
    second[2] = 2.0 * c[5] * per_reach2;
  }
  return true;
}

}  // namespace

void QuadricProjectionParams::validate() const {
  require(k >= 5, "quadric k must be >= 5, got " + std::to_string(k));
  require(normal_neighbors >= 2, "quadric normal neighbours must be >= 2, got " + std::to_string(normal_neighbors));
  require(normal_angle > 0.0 && normal_angle <= 90.0,
          "quadric normal angle must be in (0, 90] degrees, got " + std::to_string(normal_angle));
  require(degree == 2 || degree == 3, "quadric degree must be 2 or 3, got " + std::to_string(degree));
  require(curvature_reach >= 0.0 && std::isfinite(curvature_reach),
          "quadric curvature reach must be >= 0, got " + std::to_string(curvature_reach));
  require(min_k >= 10, "quadric min k must be >= 10, got " + std::to_string(min_k));
  require(passes >= 1 && passes <= 10, "quadric passes must be in 1..10, got " + std::to_string(passes));
  require(iterations >= 0 && iterations <= 20, "quadric iterations must be in 0..20, got " + std::to_string(iterations));
  require(early_degree == 2 || early_degree == 3,
          "quadric early degree must be 2 or 3, got " + std::to_string(early_degree));
  require(early_iterations >= 0 && early_iterations <= 20,
          "quadric early iterations must be in 0..20, got " + std::to_string(early_iterations));
  require(inlier_bound > 0.0, "quadric inlier bound must be > 0, got " + std::to_string(inlier_bound));
  require(placement_turn >= 0.0 && std::isfinite(placement_turn),
          "quadric placement turn must be >= 0, got " + std::to_string(placement_turn));
  require(share_stride >= 1 && share_stride <= 64,
          "quadric share stride must be in 1..64, got " + std::to_string(share_stride));
  require(share_turn >= 0.0 && std::isfinite(share_turn),
          "quadric share turn must be >= 0, got " + std::to_string(share_turn));
  frame.validate();
}

QuadricProjectionParams params_of_pass(const QuadricProjectionParams& params, int pass) {
  QuadricProjectionParams of_pass = params;
  if (pass + 1 < params.passes) {
    of_pass.degree = params.early_degree;
    of_pass.iterations = params.early_iterations;
  }
  return of_pass;
}

namespace {

// p's fit (project_to_quadric's) over `neighbors`: its robust plane, the pilot quadric's
// curvature and the Tukey-reweighted height field over the neighbours within reach.
[[gnu::always_inline]] inline QuadricFit fit_one(const Vec3& p, std::span<const Index> neighbors,
                                                 std::span<const Vec3> points, const QuadricProjectionParams& params,
                                                 Scratch& s) {
  QuadricFit fit;
  fit.origin = p;
  const std::size_t m = neighbors.size() + 1;  // p itself and its neighbours
  if (m < 6) return fit;
  s.offsets.resize(neighbors.size());
  for (std::size_t j = 0; j < neighbors.size(); ++j) s.offsets[j] = points[neighbors[j]] - p;
  s.weights.assign(m, 0.0);
  s.plane_scratch.resize(m);
  const RobustPlane plane = fit_robust_plane(s.offsets, params.frame, s.weights, s.plane_scratch);
  if (!plane.valid) return fit;
  const Vec3 n = plane.normal;
  fit.status = QuadricFit::Status::Plane;
  fit.normal = n;
  const Vec3 t1 = n.unitOrthogonal();
  const Vec3 t2 = n.cross(t1);
  s.u.resize(m);
  s.v.resize(m);
  s.h.resize(m);
  s.u[0] = s.v[0] = s.h[0] = 0.0;
  for (std::size_t j = 1; j < m; ++j) {
    const Vec3& d = s.offsets[j - 1];
    s.u[j] = d.dot(t1);
    s.v[j] = d.dot(t2);
    s.h[j] = d.dot(n);
  }
  s.residuals.resize(m);
  std::size_t count = m;
  if (params.curvature_reach > 0.0 && m > static_cast<std::size_t>(params.min_k) + 1) {
    // A pilot quadric over the nearest min_k neighbours gives the largest principal
    // curvature; the fit then takes the neighbours within curvature_reach / kappa.
    const std::size_t pilot = static_cast<std::size_t>(params.min_k) + 1;
    s.start_weights.assign(s.weights.begin(), s.weights.begin() + static_cast<std::ptrdiff_t>(pilot));
    double pilot_height = 0.0, second[3];
    if (fit_height<2>(params, pilot, s, pilot_height, second)) {
      const double mean = 0.5 * (second[0] + second[2]);
      const double diff = 0.5 * (second[0] - second[2]);
      fit.kappa = std::abs(mean) + std::sqrt(diff * diff + second[1] * second[1]);
      const double radius = params.curvature_reach / std::max(fit.kappa, 1e-300);
      count = pilot;
      while (count < m && s.u[count] * s.u[count] + s.v[count] * s.v[count] + s.h[count] * s.h[count] <= radius * radius)
        ++count;
    }
    std::copy(s.start_weights.begin(), s.start_weights.end(), s.weights.begin());
  }
  double scale = 0.0;
  const bool fitted =
      params.degree == 3
          ? fit_height<3>(params, count, s, fit.height, nullptr, &scale, fit.coefficients.data())
          : fit_height<2>(params, count, s, fit.height, nullptr, &scale, fit.coefficients.data());
  if (!fitted) return fit;
  fit.status = QuadricFit::Status::Fitted;
  // A fit that puts p farther off than the Tukey bound of its own residuals extrapolates (a
  // neighbourhood to one side, a hole's border): the move is clamped to that bound.
  fit.reach = reach_of(s, count);
  const double bound = params.inlier_bound * std::max(scale, 1e-12 * fit.reach);
  fit.clamped = std::clamp(fit.height, -bound, bound);
  return fit;
}

// The fit's height at `x` (its tangent coordinates in the fit's frame `at`, its height over
// the fit's plane `x_height`), as a move of x along the fit's normal: the fit near its origin
// with x's position along it. The fit at the origin is clamped (fit_one); the height at x is
// shifted by the same amount. An x outside the fit's reach (which the fit would extrapolate
// to) goes onto the plane at the clamped height instead.
template <int Degree>
[[gnu::always_inline]] inline double height_of_fit(const QuadricFit& fit, const double at[2]) {
  using Vec = Eigen::Matrix<double, kTerms<Degree>, 1>;
  // The fit's tangent coordinates are in units of its reach (fit_height: 1 / reach, the
  // same division).
  const double inv_reach = 1.0 / fit.reach;
  return monomials<Degree>(at[0] * inv_reach, at[1] * inv_reach).dot(Eigen::Map<const Vec>(fit.coefficients.data()));
}

[[gnu::always_inline]] inline double move_onto_fit(const QuadricFit& fit, const double at[2], double x_height,
                                                   const QuadricProjectionParams& params) {
  const double height_at = params.degree == 3 ? height_of_fit<3>(fit, at) : height_of_fit<2>(fit, at);
  // The fit keeps only neighbours whose normals lie within normal_angle of p's: its surface
  // rises from p's plane by at most tan(normal_angle) per unit along it. A fit that rises
  // faster at x extrapolates (a neighbourhood to one side): the height is bounded by that
  // slope.
  const double offset = std::sqrt(at[0] * at[0] + at[1] * at[1]);
  const double slope = std::tan(params.normal_angle * std::numbers::pi / 180.0);
  const double target = std::clamp(offset <= fit.reach ? height_at + (fit.clamped - fit.height) : fit.clamped,
                                   fit.clamped - slope * offset, fit.clamped + slope * offset);
  return target - x_height;
}

// x's tangent coordinates and height in the fit's frame.
[[gnu::always_inline]] inline double frame_coordinates(const QuadricFit& fit, const Vec3& x, double at[2]) {
  const Vec3 t1 = fit.normal.unitOrthogonal();
  const Vec3 t2 = fit.normal.cross(t1);
  const Vec3 d = x - fit.origin;
  at[0] = d.dot(t1);
  at[1] = d.dot(t2);
  return d.dot(fit.normal);
}

// p moved along the normal of its robust plane onto its fit; with an anchor, the anchor moved
// along that normal onto the same fit instead (placed_on_quadric).
[[gnu::always_inline]] inline Vec3 place_on_own_fit(const QuadricFit& fit, const Vec3* anchor,
                                                    const QuadricProjectionParams& params) {
  const Vec3& p = fit.origin;
  if (fit.status == QuadricFit::Status::None) return p;
  const Vec3& n = fit.normal;
  double at[2] = {0.0, 0.0};
  const double anchor_height = anchor != nullptr ? frame_coordinates(fit, *anchor, at) : 0.0;
  // On a surface that turns by more than placement_turn between p and the anchor, the fit's
  // height at the anchor strays from the surface more than at p (measured on the bunny and
  // the torus): the anchor is not placed, p is projected as without one.
  if (anchor != nullptr && fit.kappa >= 0.0 && fit.kappa * std::hypot(at[0], at[1]) > params.placement_turn)
    anchor = nullptr;
  if (anchor == nullptr) return fit.status == QuadricFit::Status::Fitted ? Vec3(p + fit.clamped * n) : p;
  // The anchor in p's frame: it moves along n only, onto the fit's height at its own tangent
  // coordinates. Where the fit fails, the anchor goes onto p's plane.
  if (fit.status != QuadricFit::Status::Fitted) return *anchor - anchor_height * n;
  return *anchor + move_onto_fit(fit, at, anchor_height, params) * n;
}

// A point q (at `p`, with `anchor` or none) moved along the normal of a neighbour's fit onto
// it (QuadricProjectionParams::share_stride): the anchor where the surface turns by at most
// placement_turn between it and p (as on q's own fit), else p; false where the surface turns
// by more than share_turn between the fit's origin and that point (q then fits its own).
[[gnu::always_inline]] inline bool place_on_shared_fit(const QuadricFit& fit, const Vec3& p, const Vec3* anchor,
                                                       const QuadricProjectionParams& params, Vec3& out) {
  assert(fit.status == QuadricFit::Status::Fitted && fit.kappa >= 0.0);
  const Vec3& n = fit.normal;
  if (anchor != nullptr) {
    const Vec3 along = (*anchor - p) - (*anchor - p).dot(n) * n;
    if (fit.kappa * along.norm() > params.placement_turn) anchor = nullptr;
  }
  const Vec3& x = anchor != nullptr ? *anchor : p;
  double at[2];
  const double x_height = frame_coordinates(fit, x, at);
  if (fit.kappa * std::hypot(at[0], at[1]) > params.share_turn) return false;
  out = x + move_onto_fit(fit, at, x_height, params) * n;
  return true;
}

[[gnu::always_inline]] inline Vec3 project_one(const Vec3& p, const Vec3* anchor, std::span<const Index> neighbors,
                                               std::span<const Vec3> points, const QuadricProjectionParams& params,
                                               Scratch& s) {
  return place_on_own_fit(fit_one(p, neighbors, points, params, s), anchor, params);
}

}  // namespace

Vec3 project_to_quadric(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points,
                        const QuadricProjectionParams& params) {
  Scratch s;
  return project_one(p, nullptr, neighbors, points, params, s);
}

Vec3 placed_on_quadric(const Vec3& anchor, const Vec3& p, std::span<const Index> neighbors,
                       std::span<const Vec3> points, const QuadricProjectionParams& params) {
  Scratch s;
  return project_one(p, &anchor, neighbors, points, params, s);
}

namespace {

// The normals of rows [0, out.size()) of `rows`: row r is point queries[r] of `points`, or
// first + r without queries. Four rows at a time through the batched robust plane
// (robust_plane_fit.hpp), whose every plane is the one-point fit_robust_plane's to the bit:
// their chains of square roots and divisions overlap.
void normals_of_rows(std::span<const Vec3> points, NeighborhoodsView rows, std::span<const Index> queries,
                     std::size_t first, const QuadricProjectionParams& params, std::span<Vec3> out) {
  constexpr std::size_t kLanes = 4;
  parallel_for(out.size(), [&](std::size_t begin, std::size_t end) {
    std::array<std::vector<Vec3>, kLanes> offsets;
    std::array<std::vector<double>, kLanes> weights, scratch;
    for (std::size_t r0 = begin; r0 < end; r0 += kLanes) {
      const std::size_t count = std::min(kLanes, end - r0);
      std::span<const Vec3> lane_offsets[kLanes];
      std::span<double> lane_weights[kLanes], lane_scratch[kLanes];
      for (std::size_t l = 0; l < count; ++l) {
        const std::span<const Index> nb = rows.of(r0 + l);
        const Vec3& p = points[queries.empty() ? first + r0 + l : queries[r0 + l]];
        const std::size_t m = std::min<std::size_t>(nb.size(), static_cast<std::size_t>(params.normal_neighbors));
        offsets[l].resize(m);
        for (std::size_t j = 0; j < m; ++j) offsets[l][j] = points[nb[j]] - p;
        weights[l].assign(m + 1, 0.0);
        scratch[l].resize(m + 1);
        lane_offsets[l] = offsets[l];
        lane_weights[l] = weights[l];
        lane_scratch[l] = scratch[l];
      }
      RobustPlane planes[kLanes];
      detail::fit_robust_planes<kLanes>(lane_offsets, count, params.frame, lane_weights, lane_scratch, planes);
      for (std::size_t l = 0; l < count; ++l) out[r0 + l] = planes[l].valid ? planes[l].normal : Vec3::Zero();
    }
  }, 1024);
}

}  // namespace

std::vector<Vec3> neighbourhood_normals(std::span<const Vec3> points, const Neighborhoods& neighborhoods,
                                        const QuadricProjectionParams& params) {
  params.validate();
  const std::size_t n = neighborhoods.size();
  require(points.size() == n, "neighbourhood_normals: one neighbourhood row per point");
  std::vector<Vec3> normals(n, Vec3::Zero());
  normals_of_rows(points, neighborhoods, {}, 0, params, normals);
  return normals;
}

std::vector<Vec3> normals_of_queries(std::span<const Vec3> points, NeighborhoodsView rows,
                                     std::span<const Index> queries, const QuadricProjectionParams& params) {
  require(rows.size() == queries.size(), "normals_of_queries: one neighbourhood row per query");
  std::vector<Vec3> normals(queries.size(), Vec3::Zero());
  normals_of_rows(points, rows, queries, 0, params, normals);
  return normals;
}

void project_to_quadrics(std::span<const Vec3> points, std::span<const Vec3> normals,
                         const Neighborhoods& neighborhoods, const QuadricProjectionParams& params,
                         std::span<Vec3> out) {
  const std::size_t n = neighborhoods.size();
  require(points.size() == n && normals.size() == n && out.size() == n,
          "project_to_quadrics: one neighbourhood row, normal and output per point");
  project_rows_to_quadrics(points, normals, neighborhoods, {}, params, out);
}

namespace {

// The inputs of project_rows_to_quadrics and fit_rows_to_quadrics (see there): `out` or
// `fits` receives the rows' results.
struct RowsJob {
  std::span<const Vec3> points, normals;
  NeighborhoodsView rows;
  std::span<const Index> queries;
  const QuadricProjectionParams& params;
  std::span<Vec3> out;
  std::span<const Vec3> anchors;
  const SharedFits* shared;
  std::span<QuadricFit> fits;
  std::span<char> left;
  double min_cos;
};

// The neighbours of row r on point i's face (normal within the angle of its own) into `kept`.
[[gnu::always_inline]] inline void same_face(const RowsJob& job, std::size_t r, const Vec3& ni, std::vector<Index>& kept) {
  kept.clear();
  for (const Index j : job.rows.of(r))
    if (std::abs(ni.dot(job.normals[j])) >= job.min_cos) kept.push_back(j);
}

// Row r's point moved onto the fit of the nearest seed on its face among its first
// share_candidates whose fit reaches it (place_on_shared_fit); false where there is none.
[[gnu::always_inline]] inline bool share_fit(const RowsJob& job, std::size_t r, std::size_t i, const Vec3* anchor) {
  const std::span<const Index> row = job.rows.of(r);
  const std::size_t candidates = std::min(row.size(), share_candidates(job.params));
  const Vec3& ni = job.normals[i];
  for (std::size_t c = 0; c < candidates; ++c) {
    const Index j = row[c];
    const Index f = job.shared->fit_of[j];
    if (f == SharedFits::kNoFit || !(std::abs(ni.dot(job.normals[j])) >= job.min_cos)) continue;
    const QuadricFit& fit = job.shared->fits[f];
    if (fit.status == QuadricFit::Status::Fitted && fit.kappa >= 0.0 &&
        place_on_shared_fit(fit, job.points[i], anchor, job.params, job.out[r]))
      return true;
  }
  return false;
}

// Rows [begin, end) of project_rows_to_quadrics.
[[gnu::always_inline]] inline void project_rows(const RowsJob& job, std::size_t begin, std::size_t end) {
  Scratch s;
  std::vector<Index> kept;
  const std::size_t min_k = static_cast<std::size_t>(job.params.min_k);
  const bool sharing = job.shared != nullptr;
  for (std::size_t r = begin; r < end; ++r) {
    const std::size_t i = job.queries.empty() ? r : job.queries[r];
    const Vec3& ni = job.normals[i];
    if (ni.isZero()) {  // no plane, no direction to move along
      job.out[r] = job.points[i];
      continue;
    }
    // With an anchor: whether a neighbour among the nearest min_k lies on another face (its
    // normal beyond the angle), i.e. the point is near a crease.
    bool near_crease = false;
    if (!job.anchors.empty()) {
      const std::span<const Index> row = job.rows.of(r);
      const std::size_t nearest = std::min(row.size(), min_k);
      for (std::size_t c = 0; c < nearest && !near_crease; ++c)
        near_crease = !(std::abs(ni.dot(job.normals[row[c]])) >= job.min_cos);
    }
    // Near a crease the anchor's position along the surface may lie past it, off both faces
    // (the input's noise along the surface): there the point goes where the fit puts it, as
    // in the free finish; elsewhere the anchor is placed along the normal.
    const Vec3* anchor = job.anchors.empty() || near_crease ? nullptr : &job.anchors[r];
    if (sharing) {
      const Index own = job.shared->fit_of[i];
      if (own != SharedFits::kNoFit) {
        job.out[r] = place_on_own_fit(job.shared->fits[own], anchor, job.params);
        continue;
      }
      if (share_fit(job, r, i, anchor)) continue;
      if (!job.left.empty()) {
        job.left[r] = 1;
        continue;
      }
    }
    same_face(job, r, ni, kept);
    job.out[r] = project_one(job.points[i], anchor, kept, job.points, job.params, s);
  }
}

// Rows [begin, end) of fit_rows_to_quadrics.
[[gnu::always_inline]] inline void fit_rows(const RowsJob& job, std::size_t begin, std::size_t end) {
  Scratch s;
  std::vector<Index> kept;
  for (std::size_t r = begin; r < end; ++r) {
    const std::size_t i = job.queries.empty() ? r : job.queries[r];
    const Vec3& ni = job.normals[i];
    if (ni.isZero()) {
      job.fits[r] = QuadricFit{};
      job.fits[r].origin = job.points[i];
      continue;
    }
    same_face(job, r, ni, kept);
    job.fits[r] = fit_one(job.points[i], kept, job.points, job.params, s);
  }
}

// The same source compiled for the build's baseline and for AVX2 (wider vectors for the normal
// equations' sums, each summed in the same order: the same bits). What it calls without
// inlining (the robust plane, the LDLT solve) is the baseline's.
void project_rows_plain(const RowsJob& job, std::size_t begin, std::size_t end) { project_rows(job, begin, end); }
void fit_rows_plain(const RowsJob& job, std::size_t begin, std::size_t end) { fit_rows(job, begin, end); }

#if (defined(__x86_64__) || defined(__i386__)) && (defined(__GNUC__) || defined(__clang__))
#define POINTFAIR_HAS_AVX2_FINISH 1
__attribute__((target("avx2"))) void project_rows_avx2(const RowsJob& job, std::size_t begin, std::size_t end) {
  project_rows(job, begin, end);
}
__attribute__((target("avx2"))) void fit_rows_avx2(const RowsJob& job, std::size_t begin, std::size_t end) {
  fit_rows(job, begin, end);
}
#else
#define POINTFAIR_HAS_AVX2_FINISH 0
void project_rows_avx2(const RowsJob& job, std::size_t begin, std::size_t end) { project_rows_plain(job, begin, end); }
void fit_rows_avx2(const RowsJob& job, std::size_t begin, std::size_t end) { fit_rows_plain(job, begin, end); }
#endif

using RowsBody = void (*)(const RowsJob&, std::size_t, std::size_t);

// Rows [0, n) of `job` in parallel ranges, each by the AVX2 build of the body where the
// machine has it (the default step kernel's choice), else by the baseline's.
void run_rows(const RowsJob& job, std::size_t n, RowsBody plain, RowsBody avx2) {
  const bool use_avx2 = POINTFAIR_HAS_AVX2_FINISH && default_step_kernel() == StepKernel::Avx2;
  parallel_for(n, [&](std::size_t begin, std::size_t end) { (use_avx2 ? avx2 : plain)(job, begin, end); }, 256);
}

}  // namespace

bool is_share_seed(std::uint64_t original, const QuadricProjectionParams& params) {
  if (params.share_stride <= 1) return true;
  // splitmix64's finaliser: neighbouring indices (a scan's order) get unrelated draws.
  std::uint64_t z = original + 0x9e3779b97f4a7c15ULL;
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  z ^= z >> 31;
  return z % static_cast<std::uint64_t>(params.share_stride) == 0;
}

void project_rows_to_quadrics(std::span<const Vec3> points, std::span<const Vec3> normals, NeighborhoodsView rows,
                              std::span<const Index> queries, const QuadricProjectionParams& params,
                              std::span<Vec3> out, std::span<const Vec3> anchors, const SharedFits* shared,
                              std::span<char> left_for_own_fit) {
  params.validate();
  const std::size_t n = rows.size();
  require(normals.size() == points.size() && out.size() == n && (queries.empty() || queries.size() == n) &&
              (anchors.empty() || anchors.size() == n) &&
              (shared == nullptr || shared->fit_of.size() == points.size()) &&
              (left_for_own_fit.empty() || (shared != nullptr && left_for_own_fit.size() == n)),
          "project_rows_to_quadrics: a normal (and a shared fit's index) per point, a row, an output, an anchor and "
          "a flag per query");
  const RowsJob job{points, normals, rows, queries, params, out, anchors, shared, {}, left_for_own_fit,
                    std::cos(params.normal_angle * std::numbers::pi / 180.0)};
  run_rows(job, n, project_rows_plain, project_rows_avx2);
}

void fit_rows_to_quadrics(std::span<const Vec3> points, std::span<const Vec3> normals, NeighborhoodsView rows,
                          std::span<const Index> queries, const QuadricProjectionParams& params,
                          std::span<QuadricFit> out) {
  params.validate();
  const std::size_t n = rows.size();
  require(normals.size() == points.size() && out.size() == n && (queries.empty() || queries.size() == n),
          "fit_rows_to_quadrics: a normal per point, a row and an output per query");
  const RowsJob job{points, normals, rows, queries, params, {}, {}, nullptr, out, {},
                    std::cos(params.normal_angle * std::numbers::pi / 180.0)};
  run_rows(job, n, fit_rows_plain, fit_rows_avx2);
}

Neighborhoods quadric_neighborhoods(std::span<const Vec3> points, const QuadricProjectionParams& params) {
  NeighborParams wide;
  wide.k = params.k;
  wide.eps = std::numeric_limits<double>::infinity();
  return build_neighborhoods(points, wide);
}

void finish_with_quadrics(std::vector<Vec3>& points, const QuadricProjectionParams& params,
                          std::span<const Vec3> anchors, const FinishProgress& progress) {
  params.validate();
  const std::size_t n = points.size();
  require(anchors.empty() || anchors.size() == n,
          "finish_with_quadrics: one anchor per point (" + std::to_string(anchors.size()) + " vs " +
              std::to_string(n) + ")");
  constexpr double inf = std::numeric_limits<double>::infinity();
  // The fits read each neighbour's position and normal: in the caller's order (a scan's, or
  // random) those reads miss the cache at every neighbour. They run on the cloud stored in
  // Morton order instead (`stored`, row s holding point order[s]), with every list built as
  // before in the caller's indices (the canonical tie rule) and relabelled to rows: each
  // point's fit sees the same neighbours in the same order, so no bit of the result changes.
  // The k-long lists of every point at once would hold 4 k bytes a point (800 at k 200), and
  // the normals' short ones 64 at the defaults: both are built for one block of points at a
  // time from the pass's grid (the normals of every point first, since a block's fits read
  // its neighbours' normals), in the canonical order of the whole-cloud lists.
  const int near_k = std::min(params.k, params.normal_neighbors);
  const std::vector<Index> order = spatial_order(points);
  const std::vector<Index> row_of = inverse_permutation(order);
  std::vector<Vec3> stored = gather(points, order), out(n), block_anchors;
  std::vector<Index> queries, stored_queries, own_queries;
  std::vector<std::size_t> own_rows;
  std::vector<char> left;
  std::vector<Vec3> own_out, own_anchors;
  Neighborhoods rows, own_lists;
  std::vector<Vec3> normals(n);
  // Fit sharing: the seeds' stored rows, and their fits (the same seeds every pass).
  const bool sharing = params.share_stride > 1;
  SharedFits shared;
  std::vector<Index> seeds;
  if (sharing) {
    shared.fit_of.assign(n, SharedFits::kNoFit);
    for (std::size_t s = 0; s < n; ++s)
      if (is_share_seed(order[s], params)) {
        shared.fit_of[s] = static_cast<Index>(seeds.size());
        seeds.push_back(static_cast<Index>(s));
      }
  }
  for (int pass = 0; pass < params.passes; ++pass) {
    const bool last = pass + 1 == params.passes;
    const QuadricProjectionParams fit_params = params_of_pass(params, pass);
    // One grid a pass for every block's queries (a grid a block cost a sort of the whole
    // cloud per kQuadricBlock points: quadratic in the cloud's size), and with sharing a
    // second one sized for the short lists (the normals' and the placements'): on the fits'
    // grid, with cells for 200 neighbours, each of those queries read several times the
    // candidates it needs (the 1M-point fandisk: the finish 0.91 of its time with it). The
    // cells change only the speed, never the lists.
    const int placing_k = sharing ? static_cast<int>(share_candidates(params)) : params.k;
    const CellGrid grid = build_cell_grid(points, params.k, inf);
    const std::optional<CellGrid> near_grid =
        placing_k < params.k ? std::optional(build_cell_grid(points, placing_k, inf)) : std::nullopt;
    const CellGrid& short_grid = near_grid ? *near_grid : grid;
    const auto block_queries = [&](std::size_t first, std::size_t count, int k) {
      queries.assign(order.begin() + static_cast<std::ptrdiff_t>(first),
                     order.begin() + static_cast<std::ptrdiff_t>(first + count));
      grid_neighborhoods(short_grid, queries, k, inf, rows);
      relabel_neighborhoods_in_place(rows, row_of);
    };
    for (std::size_t first = 0; first < n; first += kQuadricBlock) {
      const std::size_t count = std::min(kQuadricBlock, n - first);
      block_queries(first, count, near_k);
      normals_of_rows(stored, rows, {}, first, params, std::span<Vec3>(normals).subspan(first, count));
    }
    // Progress counts the seeds' fits and every point's placement, over all passes.
    const std::size_t per_pass = n + (sharing ? seeds.size() : 0), total = per_pass * static_cast<std::size_t>(params.passes);
    std::size_t done = static_cast<std::size_t>(pass) * per_pass;
    const auto report = [&](std::size_t more) {
      done += more;
      if (progress) progress(done, total);
    };
    if (sharing) {
      // The seeds' fits first, in parts between progress calls: every point's may share one.
      shared.fits.resize(seeds.size());
      for (std::size_t first = 0; first < seeds.size(); first += kQuadricBlock) {
        const std::size_t count = std::min(kQuadricBlock, seeds.size() - first);
        queries.resize(count);
        for (std::size_t r = 0; r < count; ++r) queries[r] = order[seeds[first + r]];
        grid_neighborhoods(grid, queries, params.k, inf, rows);
        relabel_neighborhoods_in_place(rows, row_of);
        for (std::size_t part = 0; part < count; part += kQuadricProgressBlock) {
          const std::size_t size = std::min(kQuadricProgressBlock, count - part);
          fit_rows_to_quadrics(stored, normals, NeighborhoodsView(rows).rows(part, size),
                               std::span<const Index>(seeds).subspan(first + part, size), fit_params,
                               std::span<QuadricFit>(shared.fits).subspan(first + part, size));
          report(size);
        }
      }
    }
    // With sharing, a point reads only its nearest (the crease test's and the seeds'): the
    // block's lists are that short, and the points left to fit their own get k-long ones
    // after (a prefix of the canonical order is the canonical order of fewer neighbours).
    for (std::size_t first = 0; first < n; first += kQuadricBlock) {
      const std::size_t count = std::min(kQuadricBlock, n - first);
      block_queries(first, count, placing_k);
      stored_queries.resize(count);  // row r of the block: stored point first + r
      std::iota(stored_queries.begin(), stored_queries.end(), static_cast<Index>(first));
      const bool placing = last && !anchors.empty();
      if (placing) {
        block_anchors.resize(count);
        for (std::size_t r = 0; r < count; ++r) block_anchors[r] = anchors[queries[r]];
      }
      left.assign(sharing ? count : 0, 0);
      // The block's rows in parts between progress calls (each part its own rows: the same
      // bits as the whole block at once).
      for (std::size_t part = 0; part < count; part += kQuadricProgressBlock) {
        const std::size_t size = std::min(kQuadricProgressBlock, count - part);
        const NeighborhoodsView part_rows = NeighborhoodsView(rows).rows(part, size);
        project_rows_to_quadrics(
            stored, normals, part_rows, std::span<const Index>(stored_queries).subspan(part, size), fit_params,
            std::span<Vec3>(out).subspan(first + part, size),
            placing ? std::span<const Vec3>(block_anchors).subspan(part, size) : std::span<const Vec3>{},
            sharing ? &shared : nullptr, sharing ? std::span<char>(left).subspan(part, size) : std::span<char>{});
        if (!sharing) report(size);
      }
      if (!sharing) continue;
      // The points left: their own fits over k-long lists.
      own_rows.clear();
      for (std::size_t r = 0; r < count; ++r)
        if (left[r]) own_rows.push_back(r);
      report(count - own_rows.size());
      for (std::size_t part = 0; part < own_rows.size(); part += kQuadricProgressBlock) {
        const std::size_t size = std::min(kQuadricProgressBlock, own_rows.size() - part);
        queries.resize(size);
        own_queries.resize(size);
        own_anchors.resize(placing ? size : 0);
        for (std::size_t r = 0; r < size; ++r) {
          const std::size_t row = own_rows[part + r];
          own_queries[r] = static_cast<Index>(first + row);
          queries[r] = order[first + row];
          if (placing) own_anchors[r] = block_anchors[row];
        }
        grid_neighborhoods(grid, queries, params.k, inf, own_lists);
        relabel_neighborhoods_in_place(own_lists, row_of);
        own_out.resize(size);
        project_rows_to_quadrics(stored, normals, own_lists, own_queries, fit_params, own_out, own_anchors);
        for (std::size_t r = 0; r < size; ++r) out[first + own_rows[part + r]] = own_out[r];
        report(size);
      }
    }
    // The caller's order for the next pass's lists (and the result); `out` is already the
    // next pass's stored cloud.
    for (std::size_t s = 0; s < n; ++s) points[order[s]] = out[s];
    stored.swap(out);
  }
}

}  // namespace pointfair
