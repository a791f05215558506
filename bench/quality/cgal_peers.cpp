#include "cgal_peers.hpp"

#include <tuple>

#include <CGAL/Simple_cartesian.h>
#include <CGAL/bilateral_smooth_point_set.h>
#include <CGAL/jet_smooth_point_set.h>
#include <CGAL/mst_orient_normals.h>
#include <CGAL/pca_estimate_normals.h>
#include <CGAL/property_map.h>

namespace pointfair::quality {

namespace {
using Kernel = CGAL::Simple_cartesian<double>;
using Point = Kernel::Point_3;
using Vector = Kernel::Vector_3;
using Concurrency = CGAL::Parallel_if_available_tag;
using Item = std::tuple<Point, Vector, std::size_t>;
}  // namespace

std::vector<Vec3> cgal_jet_smooth(const std::vector<Vec3>& points, int k, int passes) {
  std::vector<Point> p;
  p.reserve(points.size());
  for (const Vec3& v : points) p.emplace_back(v.x(), v.y(), v.z());
  for (int pass = 0; pass < passes; ++pass)
    CGAL::jet_smooth_point_set<Concurrency>(p, static_cast<unsigned int>(k));
  std::vector<Vec3> out;
  out.reserve(p.size());
  for (const Point& q : p) out.emplace_back(q.x(), q.y(), q.z());
  return out;
}

std::vector<Vec3> cgal_bilateral_smooth(const std::vector<Vec3>& points, int k, int passes) {
  std::vector<Item> items;
  items.reserve(points.size());
  for (std::size_t i = 0; i < points.size(); ++i)
    items.emplace_back(Point(points[i].x(), points[i].y(), points[i].z()), Vector(0, 0, 1), i);
  const auto point_map = CGAL::Nth_of_tuple_property_map<0, Item>();
  const auto normal_map = CGAL::Nth_of_tuple_property_map<1, Item>();
  for (int pass = 0; pass < passes; ++pass) {
    CGAL::pca_estimate_normals<Concurrency>(items, static_cast<unsigned int>(k),
                                            CGAL::parameters::point_map(point_map).normal_map(normal_map));
    CGAL::mst_orient_normals(items, static_cast<unsigned int>(k),
                             CGAL::parameters::point_map(point_map).normal_map(normal_map));
    CGAL::bilateral_smooth_point_set<Concurrency>(
        items, static_cast<unsigned int>(k),
        CGAL::parameters::point_map(point_map).normal_map(normal_map).sharpness_angle(25.0));
  }
  std::vector<Vec3> out(points.size());
  for (const Item& item : items) {
    const Point& q = std::get<0>(item);
    out[std::get<2>(item)] = Vec3(q.x(), q.y(), q.z());
  }
  return out;
}

}  // namespace pointfair::quality
