#include "shot.h"

#include <pcl/features/shot_omp.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <cmath>

namespace fe {

namespace {
pcl::PointCloud<pcl::PointNormal>::Ptr cloud_of(const Points& p, const Points& n) {
  pcl::PointCloud<pcl::PointNormal>::Ptr c(new pcl::PointCloud<pcl::PointNormal>);
  c->resize(static_cast<std::size_t>(p.rows()));
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    auto& q = (*c)[static_cast<std::size_t>(i)];
    q.x = static_cast<float>(p(i, 0));
    q.y = static_cast<float>(p(i, 1));
    q.z = static_cast<float>(p(i, 2));
    q.normal_x = static_cast<float>(n(i, 0));
    q.normal_y = static_cast<float>(n(i, 1));
    q.normal_z = static_cast<float>(n(i, 2));
    q.curvature = 0;
  }
  return c;
}
}  // namespace

ShotSet compute_shot(const Points& keys, const Points& key_normals, const Points& support, const Points& support_normals,
                     const std::vector<double>& radii, int threads, const std::function<bool(std::size_t)>& after_radius) {
  const Eigen::Index K = keys.rows();
  const Eigen::Index R = static_cast<Eigen::Index>(radii.size());
  ShotSet out;
  out.desc.setZero(K, kShotSize * R);
  out.valid.setConstant(K, R, false);
  out.lrf.setZero(K, 9 * R);
  if (K == 0) return out;
  auto key_cloud = cloud_of(keys, key_normals);
  auto surface = cloud_of(support, support_normals);
  pcl::search::KdTree<pcl::PointNormal>::Ptr tree(new pcl::search::KdTree<pcl::PointNormal>(false));
  tree->setInputCloud(surface);  // built once; SHOT reuses it for every radius (same surface pointer)
  for (Eigen::Index r = 0; r < R; ++r) {
    pcl::SHOTEstimationOMP<pcl::PointNormal, pcl::PointNormal, pcl::SHOT352> shot(threads > 0 ? threads : 0);
    shot.setInputCloud(key_cloud);
    shot.setSearchSurface(surface);
    shot.setInputNormals(surface);
    shot.setSearchMethod(tree);
    shot.setRadiusSearch(radii[static_cast<std::size_t>(r)]);
    pcl::PointCloud<pcl::SHOT352> d;
    shot.compute(d);
    for (Eigen::Index i = 0; i < K && static_cast<std::size_t>(i) < d.size(); ++i) {
      const float* h = d[static_cast<std::size_t>(i)].descriptor;
      bool finite = true;
      double sum = 0;
      for (int k = 0; k < kShotSize; ++k) {
        finite = finite && std::isfinite(h[k]);
        sum += std::abs(h[k]);
      }
      if (!finite || sum == 0) continue;  // fewer than 5 neighbours or degenerate frame: dropped
      const float* rf = d[static_cast<std::size_t>(i)].rf;
      bool frame_ok = true;
      for (int k = 0; k < 9; ++k) frame_ok = frame_ok && std::isfinite(rf[k]);
      if (!frame_ok) continue;
      out.valid(i, r) = true;
      for (int k = 0; k < 9; ++k) out.lrf(i, 9 * r + k) = rf[k];
      for (int k = 0; k < kShotSize; ++k) out.desc(i, kShotSize * r + k) = h[k];
    }
    if (after_radius && !after_radius(static_cast<std::size_t>(r))) throw Cancelled();
  }
  return out;
}

}  // namespace fe
