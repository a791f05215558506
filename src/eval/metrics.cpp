#include "pointfair/eval/metrics.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "pointfair/common/parallel.hpp"
#include "pointfair/common/params_error.hpp"
#include "pointfair/frames/frame.hpp"
#include "pointfair/neighbors/kd_tree.hpp"

namespace pointfair::eval {

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

void accumulate(AngleStats& s, double degrees, double& sum, double& sum2) {
  ++s.count;
  sum += degrees;
  sum2 += degrees * degrees;
}

void finish(AngleStats& s, double sum, double sum2) {
  if (s.count == 0) return;
  s.mean_degrees = sum / static_cast<double>(s.count);
  s.rms_degrees = std::sqrt(sum2 / static_cast<double>(s.count));
}

// Mean over `from` of the squared distance to the nearest point of `to` (in unit-sphere units).
double mean_nearest_squared(std::span<const Vec3> from, std::span<const Vec3> to) {
  const KdTree tree(to);
  std::vector<double> d2(from.size());
  parallel_for(from.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      Index nearest = 0;
      tree.nearest(from[i], 1, kInf, &nearest, &d2[i]);
    }
  });
  double sum = 0;
  for (const double v : d2) sum += v;
  return sum / static_cast<double>(std::max<std::size_t>(1, from.size()));
}

}  // namespace

void EvalParams::validate() const {
  require(normal_k >= 3 && normal_k <= 1024, "normal k must be in 3..1024");
  require(edge_band > 0 && edge_band < 1, "edge band must be in (0, 1) of the diagonal");
  method.validate();
}

double line_angle_degrees(const Vec3& a, const Vec3& b) {
  const double c = std::abs(a.normalized().dot(b.normalized()));
  return std::acos(std::min(1.0, c)) * 180.0 / std::numbers::pi;
}

EvalReport evaluate(const GroundTruth& truth, const EvalInput& input, const EvalParams& params) {
  params.validate();
  const auto cloud = input.cloud;
  require(!cloud.empty(), "cannot evaluate an empty cloud");
  const auto require_magnitude = [](std::span<const Vec3> points, const char* which) {
    for (std::size_t i = 0; i < points.size(); ++i)
      require(points[i].cwiseAbs().maxCoeff() <= kEvalMaxCoordinate,
              std::string("point ") + std::to_string(i) + " of the " + which +
                  " has a coordinate beyond 1e100 in magnitude, where squared distances overflow: rescale it");
  };
  require_magnitude(cloud, "cloud");
  require_magnitude(input.reference, "reference cloud");
  require_magnitude(input.input, "input cloud");
  require(input.input.empty() || input.input.size() == cloud.size(),
          "the input cloud must have as many points as the evaluated cloud");
  const std::size_t n = cloud.size();
  EvalReport r;
  r.points = n;
  const Eigen::AlignedBox3d truth_box = truth.bounds();
  r.diagonal = truth_box.diagonal().norm();
  require(r.diagonal > 0, "the truth has an empty bounding box");
  const double band = params.edge_band * r.diagonal;

  std::vector<SurfacePoint> closest(n);
  parallel_for(n, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) closest[i] = truth.closest(cloud[i]);
  }, 256);

  // PCA normals with plain k-nearest neighbourhoods.
  NeighborParams normal_neighbors;
  normal_neighbors.k = params.normal_k;
  normal_neighbors.eps = kInf;
  const Neighborhoods normal_nb = build_neighborhoods(cloud, normal_neighbors);
  std::vector<Vec3> normals(n);
  parallel_for(n, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) normals[i] = compute_frame(cloud[i], normal_nb.of(i), cloud).normal;
  });

  std::optional<PointAttributes> attributes;
  if (params.with_curvature) {
    const Neighborhoods nb = build_neighborhoods(cloud, resolve_k(params.method, cloud).neighbors);
    const double lambda = resolve_lambda(cloud, nb, params.method.flow);
    attributes = compute_attributes(cloud, nb, params.method.flow, lambda);
  }

  const bool by_reference = input.reference_in_order && input.reference.size() == n && truth.has_creases();
  double sum2 = 0, edge2 = 0, else2 = 0, signed_sum = 0;
  std::size_t n_edge = 0, n_else = 0;
  double a_sum[3] = {0, 0, 0}, a_sum2[3] = {0, 0, 0};
  double k_err2 = 0;
  std::size_t true_positive = 0;
  Eigen::AlignedBox3d cloud_box;
  for (std::size_t i = 0; i < n; ++i) {
    const SurfacePoint& s = closest[i];
    const double d = std::abs(s.signed_distance);
    sum2 += d * d;
    r.max_distance = std::max(r.max_distance, d);
    signed_sum += s.signed_distance;
    cloud_box.extend(cloud[i]);
    const bool near_edge = (by_reference ? truth.closest(input.reference[i]).crease_distance : s.crease_distance) < band;
    const double angle = line_angle_degrees(normals[i], s.normal);
    accumulate(r.normal_all, angle, a_sum[0], a_sum2[0]);
    if (near_edge) {
      edge2 += d * d;
      ++n_edge;
      accumulate(r.normal_edges, angle, a_sum[1], a_sum2[1]);
    } else {
      else2 += d * d;
      ++n_else;
      accumulate(r.normal_elsewhere, angle, a_sum[2], a_sum2[2]);
    }
    if (attributes) {
      if (s.has_curvature && !near_edge && attributes->k1[i] == attributes->k1[i]) {
        // Align the estimate's normal with the true one: flipping the normal negates and
        // swaps the principal curvatures.
        double k1 = attributes->k1[i], k2 = attributes->k2[i];
        if (attributes->normal[i].dot(s.normal) < 0) {
          const double t = -k2;
          k2 = -k1;
          k1 = t;
        }
        k_err2 += 0.5 * ((k1 - s.k1) * (k1 - s.k1) + (k2 - s.k2) * (k2 - s.k2));
        ++r.curvature_points;
      }
      const bool predicted = attributes->feature[i] != FeatureClass::Smooth;
      r.feature_predicted += predicted ? 1 : 0;
      r.feature_true += near_edge ? 1 : 0;
      true_positive += predicted && near_edge ? 1 : 0;
    }
  }
  const auto count = static_cast<double>(n);
  r.rms_distance = std::sqrt(sum2 / count) / r.diagonal;
  r.max_distance /= r.diagonal;
  r.rms_near_edges = n_edge ? std::sqrt(edge2 / static_cast<double>(n_edge)) / r.diagonal : 0.0;
  r.rms_elsewhere = n_else ? std::sqrt(else2 / static_cast<double>(n_else)) / r.diagonal : 0.0;
  r.mean_signed_distance = signed_sum / count / r.diagonal;
  r.bbox_diagonal_change = cloud_box.diagonal().norm() / r.diagonal - 1.0;
  finish(r.normal_all, a_sum[0], a_sum2[0]);
  finish(r.normal_edges, a_sum[1], a_sum2[1]);
  finish(r.normal_elsewhere, a_sum[2], a_sum2[2]);
  if (r.curvature_points > 0) r.curvature_rms = std::sqrt(k_err2 / static_cast<double>(r.curvature_points));
  if (attributes && truth.has_creases()) {
    r.feature_precision = r.feature_predicted ? static_cast<double>(true_positive) / static_cast<double>(r.feature_predicted) : 0.0;
    r.feature_recall = r.feature_true ? static_cast<double>(true_positive) / static_cast<double>(r.feature_true) : 0.0;
  }

  // Unit-sphere normalisation by the reference cloud.
  std::vector<Vec3> sampled;
  std::span<const Vec3> reference = input.reference;
  if (reference.empty()) {
    sampled = truth.sample(n, 12345).points;
    reference = sampled;
  }
  Eigen::AlignedBox3d ref_box;
  for (const Vec3& p : reference) ref_box.extend(p);
  const Vec3 centre = ref_box.center();
  double scale = 0;
  for (const Vec3& p : reference) scale = std::max(scale, (p - centre).norm());
  require(scale > 0, "the reference cloud has no extent");
  std::vector<Vec3> a(n), b(reference.size());
  for (std::size_t i = 0; i < n; ++i) a[i] = (cloud[i] - centre) / scale;
  for (std::size_t i = 0; i < b.size(); ++i) b[i] = (reference[i] - centre) / scale;
  r.chamfer_1e4 = 1e4 * (mean_nearest_squared(a, b) + mean_nearest_squared(b, a));
  r.p2m_1e4 = 1e4 * sum2 / count / (scale * scale);

  if (!input.input.empty()) {
    double max_d = 0, sum_d2 = 0;
    for (std::size_t i = 0; i < n; ++i) {
      const double d = (cloud[i] - input.input[i]).norm();
      max_d = std::max(max_d, d);
      sum_d2 += d * d;
    }
    r.max_displacement = max_d / r.diagonal;
    r.rms_displacement = std::sqrt(sum_d2 / count) / r.diagonal;
  }
  return r;
}

}  // namespace pointfair::eval
