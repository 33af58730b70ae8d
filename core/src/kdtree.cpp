#include "kdtree.h"

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>

namespace fe {

struct KdTree3::Impl {
  pcl::KdTreeFLANN<pcl::PointXYZ> tree{false};  // unsorted radius results: faster
  pcl::PointCloud<pcl::PointXYZ>::Ptr cloud{new pcl::PointCloud<pcl::PointXYZ>};
};

KdTree3::KdTree3(const Points& p) : impl_(new Impl), n_(static_cast<std::size_t>(p.rows())) {
  impl_->cloud->resize(n_);
  for (std::size_t i = 0; i < n_; ++i) {
    auto& q = (*impl_->cloud)[i];
    q.x = static_cast<float>(p(static_cast<Eigen::Index>(i), 0));
    q.y = static_cast<float>(p(static_cast<Eigen::Index>(i), 1));
    q.z = static_cast<float>(p(static_cast<Eigen::Index>(i), 2));
  }
  if (n_ > 0) impl_->tree.setInputCloud(impl_->cloud);
}

KdTree3::~KdTree3() = default;

static pcl::PointXYZ to_pcl(const Eigen::Vector3d& q) {
  return pcl::PointXYZ(static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()));
}

void KdTree3::radius(const Eigen::Vector3d& q, double r, std::vector<int>& idx, std::vector<float>& d2) const {
  idx.clear();
  d2.clear();
  if (n_ == 0 || !q.allFinite()) return;
  impl_->tree.radiusSearch(to_pcl(q), r, idx, d2);
}

int KdTree3::nearest(const Eigen::Vector3d& q, double* d2) const {
  if (n_ == 0 || !q.allFinite()) {
    if (d2) *d2 = std::numeric_limits<double>::infinity();
    return -1;
  }
  std::vector<int> idx(1);
  std::vector<float> dd(1);
  impl_->tree.nearestKSearch(to_pcl(q), 1, idx, dd);
  if (d2) *d2 = dd[0];
  return idx[0];
}

void KdTree3::knn(const Eigen::Vector3d& q, int k, std::vector<int>& idx, std::vector<float>& d2) const {
  idx.clear();
  d2.clear();
  if (n_ == 0 || !q.allFinite()) return;
  impl_->tree.nearestKSearch(to_pcl(q), std::min<int>(k, static_cast<int>(n_)), idx, d2);
}

}  // namespace fe
