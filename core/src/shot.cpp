#include "shot.h"

#include "description.h"

#include <pcl/console/print.h>
#include <pcl/features/shot_lrf_omp.h>
#include <pcl/features/shot_omp.h>
#include <pcl/point_types.h>
#include <pcl/search/kdtree.h>

#include <algorithm>
#include <cmath>
#include <mutex>
#include <unordered_map>

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

namespace {
// Indices of one support point per cube of side `h` (the first met), deterministic.
std::vector<Eigen::Index> thin(const Points& p, double h) {
  std::unordered_map<std::uint64_t, char> seen;
  std::vector<Eigen::Index> keep;
  const Eigen::RowVector3d o = p.colwise().minCoeff();
  for (Eigen::Index i = 0; i < p.rows(); ++i) {
    const Eigen::RowVector3d g = ((p.row(i) - o) / h).array().floor();
    const std::uint64_t k = (static_cast<std::uint64_t>(g(0)) & 0x1FFFFF) << 42 | (static_cast<std::uint64_t>(g(1)) & 0x1FFFFF) << 21 |
                            (static_cast<std::uint64_t>(g(2)) & 0x1FFFFF);
    if (seen.emplace(k, 1).second) keep.push_back(i);
  }
  return keep;
}
}  // namespace

ShotSet compute_shot(const Points& keys, const Points& key_normals, const Points& support, const Points& support_normals,
                     double support_spacing, const std::vector<double>& radii, int threads,
                     const std::function<bool(std::size_t)>& after_radius) {
  const Eigen::Index K = keys.rows();
  const Eigen::Index R = static_cast<Eigen::Index>(radii.size());
  ShotSet out;
  out.desc.setZero(K, kShotSize * R);
  out.valid.setConstant(K, R, false);
  out.lrf.setZero(K, 9 * R);
  if (K == 0) return out;
  // PCL reports each key point whose local frame is degenerate on stderr; such points are marked
  // invalid here (out.valid) and counted, so its per-point lines only bury the user's messages.
  static std::once_flag quiet_pcl;
  std::call_once(quiet_pcl, [] { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); });
  auto key_cloud = cloud_of(keys, key_normals);
  // Support levels: level k has spacing support_spacing * 2^k; each is built once, with its kd-tree
  // (SHOT reuses a tree whose input is the same surface pointer).
  struct Level {
    pcl::PointCloud<pcl::PointNormal>::Ptr cloud;
    pcl::search::KdTree<pcl::PointNormal>::Ptr tree;
  };
  auto level_of = [&](double radius) {
    std::size_t k = 0;
    while (support_spacing * std::pow(2.0, static_cast<double>(k + 1)) <= radius / kSupportPerRadius) ++k;
    return k;
  };
  std::size_t top = 0;
  for (const double r : radii) top = std::max(top, level_of(r));
  std::vector<Level> levels(top + 1);
  auto build = [&](std::size_t k) {
    Level& l = levels[k];
    if (k == 0) {
      l.cloud = cloud_of(support, support_normals);
    } else {
      const std::vector<Eigen::Index> idx = thin(support, support_spacing * std::pow(2.0, static_cast<double>(k)));
      Points p(static_cast<Eigen::Index>(idx.size()), 3), n(static_cast<Eigen::Index>(idx.size()), 3);
      for (std::size_t i = 0; i < idx.size(); ++i) {
        p.row(static_cast<Eigen::Index>(i)) = support.row(idx[i]);
        n.row(static_cast<Eigen::Index>(i)) = support_normals.row(idx[i]);
      }
      l.cloud = cloud_of(p, n);
    }
    l.tree.reset(new pcl::search::KdTree<pcl::PointNormal>(false));
    l.tree->setInputCloud(l.cloud);
  };
  // Every level is built before the first radius: the full support's kd-tree on one core, the
  // thinned ones on the other (each is built from the full support, so they do not wait on it).
  side_by_side([&] { build(0); },
               [&] {
                 for (std::size_t k = 1; k <= top; ++k) build(k);
               },
               top > 0);
  auto level_for = [&](double radius) -> const Level& { return levels[level_of(radius)]; };
  for (Eigen::Index r = 0; r < R; ++r) {
    const Level& level = level_for(radii[static_cast<std::size_t>(r)]);
    const auto& surface = level.cloud;
    const auto& tree = level.tree;
    // The local frames first, on the level's tree: left to itself, SHOT's frame estimation builds a
    // kd-tree of its own over the whole support, once per radius (a second each on a 900k-point part).
    pcl::SHOTLocalReferenceFrameEstimationOMP<pcl::PointNormal, pcl::ReferenceFrame> lrf;
    lrf.setNumberOfThreads(threads > 0 ? static_cast<unsigned>(threads) : 0U);
    lrf.setRadiusSearch(radii[static_cast<std::size_t>(r)]);
    lrf.setInputCloud(key_cloud);
    lrf.setSearchSurface(surface);
    lrf.setSearchMethod(tree);
    pcl::PointCloud<pcl::ReferenceFrame>::Ptr frames(new pcl::PointCloud<pcl::ReferenceFrame>);
    lrf.compute(*frames);
    pcl::SHOTEstimationOMP<pcl::PointNormal, pcl::PointNormal, pcl::SHOT352> shot(threads > 0 ? threads : 0);
    shot.setInputReferenceFrames(frames);
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
