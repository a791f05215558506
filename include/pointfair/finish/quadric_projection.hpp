#pragma once
// A finishing pass after the flow (beyond the paper): every point is moved along the normal of
// its robust plane onto a quadric height field fitted to its wide neighbourhood, as jet fitting
// does, but fitted only to the neighbours whose normals lie within an angle of the point's own
// and reweighted with Tukey's biweight of the residuals.
//
// The flow averages a point with its few nearest neighbours: on a smooth surface it stops with
// noise left that a wide second-order fit still removes. A plain wide fit bends across sharp
// edges; the normal test keeps each fit on the point's own face. Measured on the sphere and
// fandisk (README, Quality).
#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <limits>
#include <vector>
#include <functional>
#include <span>

#include "pointfair/frames/robust_frame.hpp"
#include "pointfair/neighbors/neighborhoods.hpp"
#include "pointfair/types.hpp"

namespace pointfair {

struct QuadricProjectionParams {
  /// Neighbours of the fit (the point itself not counted); at least 5.
  int k = 200;
  /// Neighbours of each point's normal (its robust plane over its nearest ones); at least 2.
  int normal_neighbors = 16;
  /// Neighbours whose normal is farther than this from the point's own (degrees, sign
  /// ignored) are left out of its fit; in (0, 90].
  double normal_angle = 30.0;
  /// Reweighting passes after the first, unweighted fit; 0..20. One measured against three
  /// (docs/defaults.md): a third less time in the finish, lower RMS on fandisk, joint, sphere
  /// and torus, 2% higher on the bunny at 0.1% noise (which curvature_reach 0.6 wins back).
  int iterations = 1;
  /// Tukey's bound in units of the robust scale of the fit's residuals (1.4826 times their
  /// median absolute value): neighbours farther off the quadric get weight 0.
  double inlier_bound = 3.0;
  /// Degree of the fitted height field: 2 (a quadric, as jet fitting) or 3 (a cubic, whose
  /// odd terms follow a neighbourhood that lies to one side of the point).
  int degree = 3;
  /// > 0: each fit takes only the neighbours within curvature_reach / kappa of the point,
  /// kappa the largest principal curvature of a pilot quadric over its min_k nearest (at
  /// least those min_k): wide fits where the surface is flat, narrow ones on fine detail.
  /// 0: all k. With one reweighting (iterations), 0.6 measured no worse than 0.7 on every
  /// smooth case of the quality benchmark; 0.5 lost 7% on the torus at 0.1% noise
  /// (docs/defaults.md).
  double curvature_reach = 0.6;
  int min_k = 40;
  /// With anchors (placed_on_quadric, SmoothParams::placement): an anchor is placed only
  /// where the surface turns by at most this angle (radians: the pilot quadric's largest
  /// curvature times the anchor's distance from p along the plane; needs curvature_reach
  /// > 0); elsewhere p is projected as without an anchor. 0.02 measured: on the bunny at 0.1%
  /// noise the RMS distance was 0.282e-3 of the diagonal with it, 0.288 with 0.05 and 0.290
  /// with no bound (the free finish: 0.280); flat and gently curved surfaces (a scan's ground
  /// and walls) keep every anchor (docs/defaults.md).
  double placement_turn = 0.02;
  /// Passes over the cloud, each with neighbourhoods, normals and fits from the last one's
  /// result; 1..10.
  int passes = 2;
  /// The passes before the last (beyond jet fitting) fit a height field of early_degree (2 or
  /// 3) with early_iterations reweightings (0..20): they only bring the points near the
  /// surface for the last pass's normals and fits, which place them. Not reweighted there,
  /// the cubic measured as good or better and cheaper: the quality benchmark's CAD models
  /// 0.3-2.4% lower RMS, the smooth ones within 1% but the torus at 0.1% noise (+2.2%); the
  /// 1M-point fandisk at 0.5% RMS 0.722 against 0.738 in 0.92 of the finish's time. A quadric
  /// there (2) scored better still on the CAD models but lost 14% on the bunny at 0.1%
  /// (docs/defaults.md).
  int early_degree = 3;
  int early_iterations = 0;
  /// Fit sharing (beyond jet fitting): 1 in share_stride points (drawn by a hash of the point's
  /// index in the input, whatever the tiling: is_share_seed) fits its own cubic, a seed; every
  /// other point takes the fit of the nearest seed on its own face among its
  /// share_candidates nearest whose fit reaches it: the surface turns by at most share_turn
  /// (radians, as placement_turn; needs curvature_reach > 0) between that seed and the point.
  /// It moves along that fit's normal onto it. The others fit their own. 1: every point fits
  /// its own; 1..64.
  int share_stride = 4;
  double share_turn = 0.1;
  /// The plane the quadric's height is measured from, and each point's normal. Its three
  /// reweightings are kept: one (as the flow's) saved 6% of the quality benchmark's time and
  /// cost up to 1.5° of normal error near creases (docs/defaults.md).
  RobustFrameParams frame;

  void validate() const;
};

/// The parameters of pass `pass` (0-based) of the finish: `params` with the degree and the
/// reweightings of the early passes for every pass before the last.
QuadricProjectionParams params_of_pass(const QuadricProjectionParams& params, int pass);

/// One point's fit, kept for its neighbours to share (QuadricProjectionParams::share_stride).
struct QuadricFit {
  /// None: no plane (fewer than 6 points, or a degenerate plane): the point stays. Plane: a
  /// plane but no height field. Fitted: both.
  enum class Status : std::uint8_t { None, Plane, Fitted };
  Vec3 origin = Vec3::Zero();  ///< the point fitted
  Vec3 normal = Vec3::Zero();  ///< its robust plane's normal
  double reach = 0.0;          ///< the farthest neighbour of the fit along the plane (its unit)
  double height = 0.0;         ///< the fit's height at the origin
  double clamped = 0.0;        ///< that height clamped to the Tukey bound of the fit's residuals
  double kappa = -1.0;         ///< the pilot quadric's largest curvature; < 0: none
  std::array<double, 10> coefficients{};  ///< the height field's, in the order of its monomials
  Status status = Status::None;
};

/// Whether the point with index `original` in the input is a seed of fit sharing.
bool is_share_seed(std::uint64_t original, const QuadricProjectionParams& params);

/// How many of a point's nearest neighbours fit sharing looks for a seed among: those of the
/// crease test (min_k), at least normal_neighbors, at most k. When only the nearest seed on
/// the face among the nearest 16 was tried, one point in seven fitted its own in the first
/// pass (fandisk, 1M points at 0.5% noise); with every seed among 40 in turn, one in thirteen
/// (docs/defaults.md).
inline std::size_t share_candidates(const QuadricProjectionParams& params) {
  return static_cast<std::size_t>(std::min(params.k, std::max(params.min_k, params.normal_neighbors)));
}

/// The seeds' fits that project_rows_to_quadrics shares: fit_of[i] is the index in `fits` of
/// point i's fit, or kNoFit.
struct SharedFits {
  static constexpr Index kNoFit = std::numeric_limits<Index>::max();
  std::vector<Index> fit_of;
  std::vector<QuadricFit> fits;
};

/// The fit of point queries[r] over row r of `rows` (its neighbours of the same face, as in
/// project_rows_to_quadrics) into out[r], for every row. Parallel.
void fit_rows_to_quadrics(std::span<const Vec3> points, std::span<const Vec3> normals, NeighborhoodsView rows,
                          std::span<const Index> queries, const QuadricProjectionParams& params,
                          std::span<QuadricFit> out);

/// The projection of p onto the quadric fitted to p and `neighbors` (indices into `points`):
/// p moved along the normal of its robust plane over them. p itself when they do not
/// determine a quadric (fewer than 6 points keep a weight, or they lie on a conic's line).
Vec3 project_to_quadric(const Vec3& p, std::span<const Index> neighbors, std::span<const Vec3> points,
                        const QuadricProjectionParams& params);

/// `anchor` moved along the normal of p's robust plane onto p's fit (project_to_quadric's),
/// evaluated at the anchor's own tangent coordinates in p's frame: the fitted surface near p
/// with the anchor's position along it. p is typically the flowed position of a point, the
/// anchor its input position. Where the fit fails, the anchor goes onto p's plane.
Vec3 placed_on_quadric(const Vec3& anchor, const Vec3& p, std::span<const Index> neighbors,
                       std::span<const Vec3> points, const QuadricProjectionParams& params);

/// The fit's neighbourhoods: each point's params.k nearest others, no radius bound.
Neighborhoods quadric_neighborhoods(std::span<const Vec3> points, const QuadricProjectionParams& params);

/// Every point's normal: the robust plane over its first params.normal_neighbors neighbours in
/// `neighborhoods` (row i: point i, nearest first). Zero where the plane is degenerate.
std::vector<Vec3> neighbourhood_normals(std::span<const Vec3> points, const Neighborhoods& neighborhoods,
                                        const QuadricProjectionParams& params);

/// The normals of some points: element r is point queries[r]'s over row r of `rows` (its
/// nearest first), as neighbourhood_normals gives it. Parallel.
std::vector<Vec3> normals_of_queries(std::span<const Vec3> points, NeighborhoodsView rows,
                                     std::span<const Index> queries, const QuadricProjectionParams& params);

/// out[i] = project_to_quadric(points[i], the neighbours j of row i with
/// |normals[i] . normals[j]| >= cos(normal_angle)), for every point. Parallel; `out` must not
/// alias `points`.
void project_to_quadrics(std::span<const Vec3> points, std::span<const Vec3> normals,
                         const Neighborhoods& neighborhoods, const QuadricProjectionParams& params,
                         std::span<Vec3> out);

/// project_to_quadrics for some points: out[r] is the projection of point queries[r] (r
/// itself when `queries` is empty) with the neighbours of row r of `rows` (indices into
/// `points`, as are `queries`); `normals` holds every point's. With `anchors` (one per row),
/// out[r] is placed_on_quadric(anchors[r], ...) instead. Parallel.
/// With `shared` (its fit_of one per point), a point whose fit is there uses it, and the others
/// share a seed's where params.share_stride allows. With `left_for_own_fit` as well (a flag
/// per row), a row whose point would fit its own is flagged and its output left as it was:
/// such rows need only their first share_candidates(params) entries.
void project_rows_to_quadrics(std::span<const Vec3> points, std::span<const Vec3> normals, NeighborhoodsView rows,
                              std::span<const Index> queries, const QuadricProjectionParams& params,
                              std::span<Vec3> out, std::span<const Vec3> anchors = {},
                              const SharedFits* shared = nullptr, std::span<char> left_for_own_fit = {});

/// Points whose k-long lists finish_with_quadrics holds at once.
inline constexpr std::size_t kQuadricBlock = std::size_t{1} << 16;
/// Points finish_with_quadrics projects between two calls of its progress (a fraction of a
/// second at the defaults on one core).
inline constexpr std::size_t kQuadricProgressBlock = std::size_t{1} << 12;

/// Progress of finish_with_quadrics: (done, total).
using FinishProgress = std::function<void(std::size_t, std::size_t)>;

/// The whole finish on a cloud, params.passes times: quadric_neighborhoods,
/// neighbourhood_normals and the projection of every point, in place (the lists built for
/// blocks of kQuadricBlock points at a time, the same rows). With `anchors` (one per point,
/// typically the input before the flow), the last pass places each anchor on its point's fit
/// (placed_on_quadric) instead of projecting the point: the surface the flow and the finish
/// found, with the anchors' positions along it. Throws ParamError on bad parameters.
/// `progress` (may throw to stop; `points` then holds the last completed pass) is called
/// after each block of at most kQuadricProgressBlock points with (work done over all passes,
/// its total): the work of a pass is its points, and with fit sharing its seeds' fits too.
void finish_with_quadrics(std::vector<Vec3>& points, const QuadricProjectionParams& params,
                          std::span<const Vec3> anchors = {}, const FinishProgress& progress = {});

}  // namespace pointfair
