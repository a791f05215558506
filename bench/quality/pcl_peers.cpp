#include "pcl_peers.hpp"

#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>
#include <pcl/surface/mls.h>

namespace pointfair::quality {

PclMlsResult pcl_mls_project(const std::vector<Vec3>& points, double radius, int order, int threads) {
  // PCL works in float: the cloud is centred first so that float keeps ~1e-7 of its size.
  Vec3 centre = Vec3::Zero();
  for (const Vec3& p : points) centre += p;
  if (!points.empty()) centre /= static_cast<double>(points.size());
  auto cloud = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
  cloud->reserve(points.size());
  for (const Vec3& p : points) {
    const Vec3 q = p - centre;
    cloud->push_back(pcl::PointXYZ(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())));
  }
  pcl::MovingLeastSquares<pcl::PointXYZ, pcl::PointXYZ> mls;
  mls.setInputCloud(cloud);
  mls.setSearchMethod(pcl::make_shared<pcl::search::KdTree<pcl::PointXYZ>>());
  mls.setSearchRadius(radius);
  mls.setPolynomialOrder(order);
  mls.setComputeNormals(false);
  mls.setUpsamplingMethod(pcl::MovingLeastSquares<pcl::PointXYZ, pcl::PointXYZ>::NONE);
  mls.setNumberOfThreads(static_cast<unsigned int>(threads));
  pcl::PointCloud<pcl::PointXYZ> output;
  mls.process(output);

  PclMlsResult result;
  result.points = points;
  std::vector<char> placed(points.size(), 0);
  const auto& corresponding = mls.getCorrespondingIndices()->indices;
  for (std::size_t k = 0; k < output.size() && k < corresponding.size(); ++k) {
    const auto i = static_cast<std::size_t>(corresponding[k]);
    const auto& q = output[k];
    result.points[i] = centre + Vec3(q.x, q.y, q.z);
    placed[i] = 1;
  }
  for (const char p : placed) result.kept_input += p ? 0 : 1;
  return result;
}

}  // namespace pointfair::quality
