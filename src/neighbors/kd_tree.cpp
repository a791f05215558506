#include "pointfair/neighbors/kd_tree.hpp"

#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

#include <nanoflann.hpp>

#include "pointfair/common/params_error.hpp"

namespace pointfair {
namespace {

// nanoflann's dataset adaptor over a flat Vec3 array: no copy.
struct PointsAdaptor {
  std::span<const Vec3> points;
  std::size_t kdtree_get_point_count() const { return points.size(); }
  double kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i][static_cast<Eigen::Index>(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const { return false; }
};

using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>,
                                                 PointsAdaptor, 3, Index>;

// A bounded k-nearest result set with a canonical order: by squared distance, then by index.
// nanoflann visits every node whose distance bound is <= the current worst distance, so
// points tied with the k-th are all offered and the smaller index wins.
// The next larger double of a squared distance (>= 0, finite or +inf), without a libm call.
inline double next_up(double x) {
  if (!(x < std::numeric_limits<double>::infinity())) return x;
  if (x == 0.0) return std::numeric_limits<double>::denorm_min();
  return std::bit_cast<double>(std::bit_cast<std::uint64_t>(x) + 1);
}

// The bound reported to nanoflann for a worst squared distance x: nanoflann offers a point only
// if its distance is strictly below it (hence the next larger double, so that a point tied
// with the worst is still offered), and prunes a node when its incrementally summed distance
// bound exceeds it. That sum can round a few ulps above the true bound of the node, which would
// lose points tied with the worst in a node beside it (stacks of duplicates spread over several
// leaves); the relative 1e-12 covers that rounding. Only a few more nodes are visited, and
// addPoint still decides each point exactly.
inline double search_bound(double x) { return next_up(x * (1.0 + 1e-12)); }

class CanonicalKnn {
 public:
  using DistanceType = double;
  using IndexType = Index;

  // `original` maps the tree's internal (leaf-ordered) indices to the caller's indices;
  // results and the tie rule use the caller's indices.
  CanonicalKnn(int capacity, double max_distance2, const Index* original, Index* indices,
               double* distances2)
      : capacity_(capacity),
        max_distance2_(max_distance2),
        original_(original),
        indices_(indices),
        dists_(distances2) {}

  int size() const { return count_; }
  bool full() const { return count_ == capacity_; }

  bool addPoint(double dist, Index internal) {
    if (dist > max_distance2_) return true;
    const Index index = original_[internal];
    if (full() && !before(dist, index, dists_[count_ - 1], indices_[count_ - 1])) return true;
    int i = full() ? count_ - 1 : count_;
    while (i > 0 && before(dist, index, dists_[i - 1], indices_[i - 1])) {
      dists_[i] = dists_[i - 1];
      indices_[i] = indices_[i - 1];
      --i;
    }
    dists_[i] = dist;
    indices_[i] = index;
    if (!full()) ++count_;
    if (full()) worst_ = search_bound(dists_[count_ - 1]);
    return true;
  }

  double worstDist() const { return worst_; }

 private:
  static bool before(double d, Index i, double d2, Index i2) { return d < d2 || (d == d2 && i < i2); }

  int capacity_;
  double max_distance2_;
  const Index* original_;
  Index* indices_;
  double* dists_;
  int count_ = 0;
  double worst_ = search_bound(max_distance2_);
};

}  // namespace

// The tree is built over the caller's points, then the points are copied in the tree's leaf
// order and the tree is pointed at the copy: leaf scans then read contiguous memory instead
// of jumping through the caller's array. `original` maps copy positions back.
struct KdTree::Impl {
  std::span<const Vec3> points;
  std::vector<Vec3> ordered;
  std::vector<Index> original;
  PointsAdaptor adaptor;
  Tree tree;
  explicit Impl(std::span<const Vec3> pts)
      : points(pts), adaptor{pts}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {
    tree.buildIndex();
    original.assign(tree.vAcc.begin(), tree.vAcc.end());
    ordered.resize(original.size());
    for (std::size_t i = 0; i < original.size(); ++i) {
      ordered[i] = pts[original[i]];
      tree.vAcc[i] = static_cast<Index>(i);
    }
    adaptor.points = ordered;
  }
};

KdTree::KdTree(std::span<const Vec3> points) {
  require_finite(points, "k-d tree");
  impl_ = std::make_unique<Impl>(points);
}
KdTree::~KdTree() = default;
KdTree::KdTree(KdTree&&) noexcept = default;
KdTree& KdTree::operator=(KdTree&&) noexcept = default;

std::span<const Vec3> KdTree::points() const { return impl_->points; }

std::span<const Index> KdTree::leaf_order() const { return impl_->original; }

int KdTree::nearest(const Vec3& query, int k, double max_distance2, Index* indices,
                    double* distances2) const {
  if (k <= 0 || impl_->points.empty()) return 0;
  CanonicalKnn result(k, max_distance2, impl_->original.data(), indices, distances2);
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  return result.size();
}

}  // namespace pointfair
