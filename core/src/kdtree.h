// Internal: a 3-D kd-tree over Eigen points (nanoflann behind a pimpl, so only kdtree.cpp pays for
// its header). Queries are const and thread-safe.
#pragma once

#include "featureextract/mesh.h"

#include <memory>
#include <vector>

namespace fe {

class KdTree3 {
 public:
  explicit KdTree3(const Points& points);
  ~KdTree3();
  KdTree3(const KdTree3&) = delete;
  KdTree3& operator=(const KdTree3&) = delete;

  /// Indices (and squared distances) of points within r of q, unsorted.
  void radius(const Eigen::Vector3d& q, double r, std::vector<int>& idx, std::vector<float>& d2) const;
  /// Nearest point index (or -1 for an empty tree); squared distance in *d2.
  int nearest(const Eigen::Vector3d& q, double* d2 = nullptr) const;
  /// Nearest point strictly within r of q (-1 when there is none, or q is not finite); squared
  /// distance in *d2. The same point nearest() gives whenever that one lies within r, found without
  /// visiting the tree beyond r: the cheap query for errors that are truncated at r anyway.
  int nearest_within(const Eigen::Vector3d& q, double r, double* d2 = nullptr) const;
  /// k nearest, sorted by distance.
  void knn(const Eigen::Vector3d& q, int k, std::vector<int>& idx, std::vector<float>& d2) const;
  std::size_t size() const { return n_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::size_t n_ = 0;
};

}  // namespace fe
