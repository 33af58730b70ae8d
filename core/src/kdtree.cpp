// KdTree3 on nanoflann (header-only; faster than FLANN for the many small radius and nearest
// queries of normals, curvature and RANSAC scoring). PCL's own tree is used only inside SHOT.
#include "kdtree.h"

#include <cmath>
#include <nanoflann.hpp>

#include <limits>

namespace fe {

namespace {
struct Cloud {
  std::vector<float> xyz;
  std::size_t kdtree_get_point_count() const { return xyz.size() / 3; }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return xyz[3 * i + d]; }
  template <class B>
  bool kdtree_get_bbox(B&) const { return false; }
};
using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3, int>;
}  // namespace

struct KdTree3::Impl {
  Cloud cloud;
  std::unique_ptr<Index> index;
};

KdTree3::KdTree3(const Points& p) : impl_(new Impl), n_(static_cast<std::size_t>(p.rows())) {
  impl_->cloud.xyz.resize(3 * n_);
  for (std::size_t i = 0; i < n_; ++i)
    for (int d = 0; d < 3; ++d) {
      const double x = p(static_cast<Eigen::Index>(i), d);
      // a non-finite point (a projective map's point at infinity) must not corrupt the tree: it goes
      // so far away that no query finds it
      impl_->cloud.xyz[3 * i + static_cast<std::size_t>(d)] = std::isfinite(x) ? static_cast<float>(x) : 1e30f;
    }
  if (n_ > 0) {
    impl_->index = std::make_unique<Index>(3, impl_->cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
    impl_->index->buildIndex();
  }
}

KdTree3::~KdTree3() = default;

void KdTree3::radius(const Eigen::Vector3d& q, double r, std::vector<int>& idx, std::vector<float>& d2) const {
  idx.clear();
  d2.clear();
  if (n_ == 0 || !q.allFinite()) return;
  const float p[3] = {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
  thread_local std::vector<std::pair<int, float>> hits;
  hits.clear();
  nanoflann::SearchParams sp;
  sp.sorted = false;
  impl_->index->radiusSearch(p, static_cast<float>(r * r), hits, sp);
  idx.reserve(hits.size());
  d2.reserve(hits.size());
  for (const auto& h : hits) {
    idx.push_back(h.first);
    d2.push_back(h.second);
  }
}

int KdTree3::nearest(const Eigen::Vector3d& q, double* d2) const {
  if (n_ == 0 || !q.allFinite()) {
    if (d2) *d2 = std::numeric_limits<double>::infinity();
    return -1;
  }
  const float p[3] = {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
  int i = -1;
  float dd = 0;
  impl_->index->knnSearch(p, 1, &i, &dd);
  if (d2) *d2 = dd;
  return i;
}

int KdTree3::nearest_within(const Eigen::Vector3d& q, double r, double* d2) const {
  if (d2) *d2 = std::numeric_limits<double>::infinity();
  if (n_ == 0 || !q.allFinite() || !(r > 0)) return -1;
  const float p[3] = {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
  int i = -1;
  float dd = 0;
  nanoflann::KNNResultSet<float, int, std::size_t> rs(1);
  rs.init(&i, &dd);
  dd = static_cast<float>(r * r);  // the worst distance accepted: nodes beyond r are never opened
  impl_->index->findNeighbors(rs, p, nanoflann::SearchParams());
  if (rs.size() == 0) return -1;
  if (d2) *d2 = dd;
  return i;
}

void KdTree3::knn(const Eigen::Vector3d& q, int k, std::vector<int>& idx, std::vector<float>& d2) const {
  idx.clear();
  d2.clear();
  if (n_ == 0 || !q.allFinite()) return;
  const float p[3] = {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z())};
  const std::size_t kk = std::min<std::size_t>(static_cast<std::size_t>(std::max(k, 0)), n_);
  idx.resize(kk);
  d2.resize(kk);
  const std::size_t found = impl_->index->knnSearch(p, kk, idx.data(), d2.data());
  idx.resize(found);
  d2.resize(found);
}

}  // namespace fe
