#include "pairing.h"

#include "kdtree.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <map>
#include <cmath>
#include <numeric>

namespace fe {

std::vector<KeyPointPair> shot_pairs(const ShotSet& ref, const ShotSet& tgt, int m, int D, int U, int N,
                                     const std::function<bool(double)>& progress) {
  const Eigen::Index Kr = ref.desc.rows(), Kt = tgt.desc.rows();
  std::vector<KeyPointPair> out;
  if (Kr == 0 || Kt == 0) return out;
  const Eigen::Index W = static_cast<Eigen::Index>(kShotSize) * m;
  // reference rows valid over all m radii
  std::vector<int> rrows;
  for (Eigen::Index j = 0; j < Kr; ++j)
    if (ref.valid.row(j).head(m).all()) rrows.push_back(static_cast<int>(j));
  if (rrows.empty()) return out;
  Eigen::MatrixXf R(static_cast<Eigen::Index>(rrows.size()), W);
  for (std::size_t a = 0; a < rrows.size(); ++a) R.row(static_cast<Eigen::Index>(a)) = ref.desc.row(rrows[a]).head(W);
  const Eigen::VectorXf rn = R.rowwise().squaredNorm();

  // Chunks of target rows run in parallel, each with a single-threaded product (Eigen's own threading
  // is off, EIGEN_DONT_PARALLELIZE: its blocking depends on the thread count, and so would the float
  // sums and the chosen pairs; this way the result is the same for any number of threads).
  const Eigen::Index chunk = 256;
  const Eigen::Index nchunks = (Kt + chunk - 1) / chunk, batch = 8;
  const int shifts = D + U + 1;
  std::vector<std::vector<std::pair<float, std::pair<int, int>>>> cand(static_cast<std::size_t>(Kt));
  for (Eigen::Index b0 = 0; b0 < nchunks; b0 += batch) {
    const Eigen::Index b1 = std::min(nchunks, b0 + batch);
#pragma omp parallel for schedule(dynamic, 1)
    for (Eigen::Index ci = b0; ci < b1; ++ci) {
      const Eigen::Index c0 = ci * chunk;
      const Eigen::Index n = std::min(chunk, Kt - c0);
      for (int s = 0; s < shifts; ++s) {  // window starts at target radius index s (shift s - D)
        if (s + m > tgt.valid.cols()) break;
        const Eigen::MatrixXf T = tgt.desc.block(c0, static_cast<Eigen::Index>(kShotSize) * s, n, W);
        const Eigen::VectorXf tn = T.rowwise().squaredNorm();
        const Eigen::MatrixXf dot = T * R.transpose();  // n x Kr'
        for (Eigen::Index i = 0; i < n; ++i) {
          if (!tgt.valid.row(c0 + i).segment(s, m).all()) continue;
          auto& cs = cand[static_cast<std::size_t>(c0 + i)];
          for (Eigen::Index a = 0; a < dot.cols(); ++a) {
            const float d2 = std::max(0.0f, tn(i) + rn(a) - 2 * dot(i, a));
            cs.push_back({d2, {rrows[static_cast<std::size_t>(a)], s - D}});
          }
          // keep the best N * shifts (enough for N distinct reference points) to bound memory
          const std::size_t keep = static_cast<std::size_t>(N) * static_cast<std::size_t>(shifts);
          if (cs.size() > keep) {
            std::nth_element(cs.begin(), cs.begin() + static_cast<long>(keep), cs.end());
            cs.resize(keep);
          }
        }
      }
    }
    if (progress && !progress(static_cast<double>(std::min(Kt, b1 * chunk)) / static_cast<double>(Kt))) throw Cancelled();
  }
  for (Eigen::Index i = 0; i < Kt; ++i) {
    auto& cs = cand[static_cast<std::size_t>(i)];
    std::sort(cs.begin(), cs.end());
    std::vector<int> used;
    for (const auto& c : cs) {
      if (static_cast<int>(used.size()) >= N) break;
      if (std::find(used.begin(), used.end(), c.second.first) != used.end()) continue;  // best shift only
      used.push_back(c.second.first);
      out.push_back({c.second.first, static_cast<int>(i), c.second.second, std::sqrt(c.first / static_cast<float>(m))});
    }
  }
  return out;
}

std::vector<std::vector<int>> si_pairs(const Eigen::VectorXd& ref_si, const Eigen::VectorXd& tgt_si, int M, double max_difference) {
  std::vector<int> order(static_cast<std::size_t>(ref_si.size()));
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](int a, int b) { return ref_si(a) < ref_si(b) || (ref_si(a) == ref_si(b) && a < b); });
  std::vector<double> sorted(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) sorted[k] = ref_si(order[k]);
  std::vector<std::vector<int>> out(static_cast<std::size_t>(tgt_si.size()));
  for (Eigen::Index i = 0; i < tgt_si.size(); ++i) {
    const double v = tgt_si(i);
    // merge outwards from the insertion point
    long hi = std::lower_bound(sorted.begin(), sorted.end(), v) - sorted.begin();
    long lo = hi - 1;
    auto& o = out[static_cast<std::size_t>(i)];
    while (static_cast<int>(o.size()) < M && (lo >= 0 || hi < static_cast<long>(sorted.size()))) {
      const bool take_hi = lo < 0 || (hi < static_cast<long>(sorted.size()) && std::abs(sorted[static_cast<std::size_t>(hi)] - v) < std::abs(sorted[static_cast<std::size_t>(lo)] - v));
      if (std::abs(sorted[static_cast<std::size_t>(take_hi ? hi : lo)] - v) > max_difference) break;
      o.push_back(order[static_cast<std::size_t>(take_hi ? hi++ : lo--)]);
    }
  }
  return out;
}

std::vector<KeyPointPair> filter_by_shape_index(const std::vector<KeyPointPair>& shot, const Points& ref_keys,
                                                const Points& tgt_keys, const std::vector<std::vector<int>>& si,
                                                double delta_ref, double delta_tgt, double ratio) {
  std::vector<KeyPointPair> out;
  if (shot.empty()) return out;
  KdTree3 ttree(tgt_keys), rtree(ref_keys);
  std::vector<int> tnear, rnear;
  std::vector<float> d2;
  std::vector<char> mark(static_cast<std::size_t>(ref_keys.rows()), 0);
  for (const KeyPointPair& p : shot) {
    const double dt = delta_tgt * std::pow(ratio, p.shift);
    ttree.radius(tgt_keys.row(p.tgt).transpose(), dt, tnear, d2);
    std::vector<int> marked;
    for (int m : tnear)
      for (int n : si[static_cast<std::size_t>(m)])
        if (!mark[static_cast<std::size_t>(n)]) { mark[static_cast<std::size_t>(n)] = 1; marked.push_back(n); }
    rtree.radius(ref_keys.row(p.ref).transpose(), delta_ref, rnear, d2);
    bool keep = false;
    for (int n : rnear) keep = keep || mark[static_cast<std::size_t>(n)];
    for (int n : marked) mark[static_cast<std::size_t>(n)] = 0;
    if (keep) out.push_back(p);
  }
  return out;
}

std::vector<std::vector<int>> euclidean_clusters(const Points& pts, double tol) {
  const Eigen::Index n = pts.rows();
  std::vector<int> label(static_cast<std::size_t>(n), -1);
  std::vector<std::vector<int>> clusters;
  if (n == 0) return clusters;
  KdTree3 tree(pts);
  std::vector<int> near;
  std::vector<float> d2;
  for (Eigen::Index s = 0; s < n; ++s) {
    if (label[static_cast<std::size_t>(s)] >= 0) continue;
    const int id = static_cast<int>(clusters.size());
    clusters.emplace_back();
    std::vector<int> stack{static_cast<int>(s)};
    label[static_cast<std::size_t>(s)] = id;
    while (!stack.empty()) {
      const int q = stack.back();
      stack.pop_back();
      clusters.back().push_back(q);
      tree.radius(pts.row(q).transpose(), tol, near, d2);
      for (int r : near)
        if (label[static_cast<std::size_t>(r)] < 0) { label[static_cast<std::size_t>(r)] = id; stack.push_back(r); }
    }
    std::sort(clusters.back().begin(), clusters.back().end());
  }
  return clusters;
}


std::vector<std::vector<int>> vote_groups(const Points& votes, const std::vector<double>& scales, double cell, double reach,
                                          int min_pairs) {
  std::vector<std::vector<int>> groups;
  const Eigen::Index n = votes.rows();
  if (n == 0 || !(cell > 0)) return groups;
  auto key_of = [&](const Eigen::Vector3d& v) {
    const Eigen::Vector3d g = (v / cell).array().floor();
    return std::array<long long, 3>{static_cast<long long>(g.x()), static_cast<long long>(g.y()), static_cast<long long>(g.z())};
  };
  std::map<std::array<long long, 3>, std::vector<int>> cells;
  for (Eigen::Index i = 0; i < n; ++i)
    if (votes.row(i).allFinite()) cells[key_of(votes.row(i).transpose())].push_back(static_cast<int>(i));
  std::vector<char> used(static_cast<std::size_t>(n), 0);
  auto live = [&](const std::vector<int>& c) {
    int k = 0;
    for (int i : c) k += used[static_cast<std::size_t>(i)] ? 0 : 1;
    return k;
  };
  for (int round = 0; round < 1000; ++round) {
    // the densest 3 x 3 x 3 block of cells (ties: the first in key order, so the result is deterministic)
    int best = 0;
    std::array<long long, 3> at{};
    for (const auto& c : cells) {
      if (live(c.second) == 0) continue;
      int sum = 0;
      for (long long dx = -1; dx <= 1; ++dx)
        for (long long dy = -1; dy <= 1; ++dy)
          for (long long dz = -1; dz <= 1; ++dz) {
            const auto it = cells.find({c.first[0] + dx, c.first[1] + dy, c.first[2] + dz});
            if (it != cells.end()) sum += live(it->second);
          }
      if (sum > best) { best = sum; at = c.first; }
    }
    if (best < min_pairs) break;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    int cnt = 0;
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto it = cells.find({at[0] + dx, at[1] + dy, at[2] + dz});
          if (it == cells.end()) continue;
          for (int i : it->second)
            if (!used[static_cast<std::size_t>(i)]) { mean += votes.row(i).transpose(); ++cnt; }
        }
    mean /= std::max(1, cnt);
    std::vector<int> g;
    for (Eigen::Index i = 0; i < n; ++i)
      if (!used[static_cast<std::size_t>(i)] && votes.row(i).allFinite() &&
          (votes.row(i).transpose() - mean).norm() <= reach * scales[static_cast<std::size_t>(i)])
        g.push_back(static_cast<int>(i));
    if (static_cast<int>(g.size()) < min_pairs) {
      // the block's pairs are too spread around their mean: take them out of the running
      for (long long dx = -1; dx <= 1; ++dx)
        for (long long dy = -1; dy <= 1; ++dy)
          for (long long dz = -1; dz <= 1; ++dz) {
            const auto it = cells.find({at[0] + dx, at[1] + dy, at[2] + dz});
            if (it != cells.end() && dx == 0 && dy == 0 && dz == 0)
              for (int i : it->second) used[static_cast<std::size_t>(i)] = 1;
          }
      continue;
    }
    for (int i : g) used[static_cast<std::size_t>(i)] = 1;
    groups.push_back(std::move(g));
  }
  return groups;
}

}  // namespace fe
