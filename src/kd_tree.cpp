#include "pointfair/kd_tree.hpp"

#include <cmath>
#include <limits>

#include <nanoflann.hpp>

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
class CanonicalKnn {
 public:
  using DistanceType = double;
  using IndexType = Index;

  CanonicalKnn(int capacity, double max_distance2, Index* indices, double* distances2)
      : capacity_(capacity), max_distance2_(max_distance2), indices_(indices), dists_(distances2) {}

  int size() const { return count_; }
  bool full() const { return count_ == capacity_; }

  bool addPoint(double dist, Index index) {
    if (dist > max_distance2_) return true;
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
    return true;
  }

  // nanoflann offers a point only if its distance is strictly below worstDist(); report the
  // next larger double so that a point tied with the current worst is still offered.
  double worstDist() const {
    const double worst = full() ? dists_[count_ - 1] : max_distance2_;
    return std::nextafter(worst, std::numeric_limits<double>::infinity());
  }

 private:
  static bool before(double d, Index i, double d2, Index i2) { return d < d2 || (d == d2 && i < i2); }

  int capacity_;
  double max_distance2_;
  Index* indices_;
  double* dists_;
  int count_ = 0;
};

}  // namespace

struct KdTree::Impl {
  PointsAdaptor adaptor;
  Tree tree;
  explicit Impl(std::span<const Vec3> points)
      : adaptor{points}, tree(3, adaptor, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {
    tree.buildIndex();
  }
};

KdTree::KdTree(std::span<const Vec3> points) : impl_(std::make_unique<Impl>(points)) {}
KdTree::~KdTree() = default;
KdTree::KdTree(KdTree&&) noexcept = default;
KdTree& KdTree::operator=(KdTree&&) noexcept = default;

std::span<const Vec3> KdTree::points() const { return impl_->adaptor.points; }

int KdTree::nearest(const Vec3& query, int k, double max_distance2, Index* indices,
                    double* distances2) const {
  if (k <= 0 || impl_->adaptor.points.empty()) return 0;
  CanonicalKnn result(k, max_distance2, indices, distances2);
  impl_->tree.findNeighbors(result, query.data(), nanoflann::SearchParams());
  return result.size();
}

}  // namespace pointfair
