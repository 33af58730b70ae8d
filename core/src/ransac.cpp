// Step 6 (paper 3.8): RANSAC over key point pairs with minimal samples of 5 and the paper's
// stopping rule (no improvement for `patience` iterations, or an upper bound). Samples are drawn
// around a random first pair, from pairs whose distances agree with it (guided sampling), and
// degenerate (near-coplanar) samples are skipped before solving.
#include "featureextract/geometry.h"
#include "kdtree.h"

#include <Eigen/Geometry>  // .cross()
#include <random>

namespace fe {

namespace {

// |volume| of the five tetrahedra of 4 of the 5 points, after normalizing the points to
// mean 0 and RMS distance 1 (so the test is scale-free). A regular configuration gives ~0.5.
// Smallest and largest |volume| of the five 4-point tetrahedra (see above).
std::pair<double, double> tetra_volumes(const Eigen::Matrix<double, 5, 3>& p) {
  const Eigen::RowVector3d mean = p.colwise().mean();
  Eigen::Matrix<double, 5, 3> q = p.rowwise() - mean;
  const double rms = std::sqrt(q.squaredNorm() / 5.0);
  if (!(rms > 0)) return {0.0, 0.0};
  q /= rms;
  double v = INFINITY, w = 0;
  for (int skip = 0; skip < 5; ++skip) {
    int idx[4], k = 0;
    for (int i = 0; i < 5; ++i)
      if (i != skip) idx[k++] = i;
    const Eigen::Vector3d a = q.row(idx[1]) - q.row(idx[0]), b = q.row(idx[2]) - q.row(idx[0]), c = q.row(idx[3]) - q.row(idx[0]);
    const double vol = std::abs(a.dot(b.cross(c))) / 6.0;
    v = std::min(v, vol);
    w = std::max(w, vol);
  }
  return {v, w};
}

}  // namespace

RansacResult ransac_projective(const Points& ref, const Points& tgt, const std::function<double(const Eigen::Matrix4d&)>& cost,
                               const RansacOptions& o, const std::function<bool()>& cancelled) {
  return ransac_projective(ref, tgt, std::function<double(const Eigen::Matrix4d&, double)>([&](const Eigen::Matrix4d& H, double) { return cost(H); }), o,
                           cancelled);
}

RansacResult ransac_projective(const Points& ref, const Points& tgt, const std::function<double(const Eigen::Matrix4d&, double)>& cost,
                               const RansacOptions& o, const std::function<bool()>& cancelled) {
  RansacResult best;
  best.cost = INFINITY;
  const int n = static_cast<int>(ref.rows());
  if (n < 5 || tgt.rows() != ref.rows()) return best;
  std::mt19937_64 rng(o.seed);
  KdTree3 tree(tgt);
  std::vector<int> near, cand;
  std::vector<float> d2;
  const double eps = 1e-9 * std::max(1.0, (tgt.colwise().maxCoeff() - tgt.colwise().minCoeff()).norm());
  double rmin = o.ratio_min, rmax = o.ratio_max;  // for the current sample
  auto consistent = [&](int a, int b) {
    const double dr = (ref.row(a) - ref.row(b)).norm(), dt = (tgt.row(a) - tgt.row(b)).norm();
    if (dr <= eps || dt <= eps) return false;
    if (rmax > 0) return dt >= rmin * dr && dt <= rmax * dr;
    return true;
  };
  // One iteration's draw: a hypothesis H and its sample, or nothing (a degenerate or thin sample).
  struct Draw {
    bool ok = false;
    Eigen::Matrix4d H;
    std::array<int, 5> sample;
    bool affine = false;
    double cost = INFINITY;
  };
  // A draw's candidates (the pairs around its first pair that agree with it) depend on the first pair
  // alone, so each first pair's list is made once and kept. Same lists in the same order, so the same
  // draws. It pays where a search draws the same first pairs again (a library's small features: 20
  // MFCAD features 0.94x); CTC-02's 25,000 pairs are seldom drawn twice (no gain). Kept up to
  // kCandidateCache entries in all (past that, lists are made each time as before).
  constexpr std::size_t kCandidateCache = std::size_t{1} << 22;
  std::vector<std::vector<int>> candidates_of(static_cast<std::size_t>(n));
  std::vector<char> listed(static_cast<std::size_t>(n), 0);
  std::size_t cached = 0;
  auto draw = [&](Draw& d) {
    d.ok = false;
    const int first = static_cast<int>(rng() % static_cast<std::uint64_t>(n));
    double locality = o.locality;
    rmin = o.ratio_min;
    rmax = o.ratio_max;
    if (o.scales) {
      const double sc = (*o.scales)[static_cast<std::size_t>(first)];
      locality *= sc;
      rmin = std::max(rmin, sc / 2);
      rmax = rmax > 0 ? std::min(rmax, 2 * sc) : 2 * sc;
    }
    const std::size_t fi = static_cast<std::size_t>(first);
    if (!listed[fi]) {
      if (locality > 0) {
        tree.radius(tgt.row(first).transpose(), locality, near, d2);
      } else {
        near.resize(static_cast<std::size_t>(n));
        for (int i = 0; i < n; ++i) near[static_cast<std::size_t>(i)] = i;
      }
      cand.clear();
      const double cos_max = std::cos(o.max_angle);
      for (int c : near) {
        if (c == first || !consistent(first, c)) continue;
        if (o.rotations) {
          const Eigen::Vector3d pr = (*o.rotations)[fi] * (ref.row(c) - ref.row(first)).transpose();
          const Eigen::Vector3d dt = (tgt.row(c) - tgt.row(first)).transpose();
          if (!(pr.dot(dt) >= cos_max * pr.norm() * dt.norm())) continue;
        }
        cand.push_back(c);
      }
      if (cached + cand.size() <= kCandidateCache) {
        cached += cand.size();
        candidates_of[fi].swap(cand);
        listed[fi] = 1;
      }
    }
    const std::vector<int>& cand_here = listed[fi] ? candidates_of[fi] : cand;
    if (cand_here.size() < 4) return;
    std::array<int, 5> s{{first, -1, -1, -1, -1}};
    int filled = 1;
    for (int attempt = 0; attempt < 60 && filled < 5; ++attempt) {
      const int c = cand_here[rng() % cand_here.size()];
      bool ok = true;
      for (int k = 1; k < filled && ok; ++k) ok = c != s[static_cast<std::size_t>(k)] && consistent(c, s[static_cast<std::size_t>(k)]);
      if (ok) s[static_cast<std::size_t>(filled++)] = c;
    }
    if (filled < 5) return;
    Eigen::Matrix<double, 5, 3> r, t;
    for (int k = 0; k < 5; ++k) {
      r.row(k) = ref.row(s[static_cast<std::size_t>(k)]);
      t.row(k) = tgt.row(s[static_cast<std::size_t>(k)]);
    }
    // The paper's 5-pair projective solve when the sample determines it; when 4 of the 5 points
    // are (nearly) coplanar it does not, and an affine fit on the same 5 pairs is used instead.
    const auto vr = tetra_volumes(r), vt = tetra_volumes(t);
    if (!o.affine_only && std::min(vr.first, vt.first) >= o.min_tetra_volume) {
      if (!solve_projective_5(r, t, d.H)) return;
    } else if (std::min(vr.second, vt.second) >= o.min_tetra_volume) {
      if (!fit_affine(Points(r), Points(t), d.H)) return;
      d.affine = true;
    } else {
      return;
    }
    d.sample = s;
    d.ok = true;
  };
  const int batch = std::max(1, o.batch);
  std::vector<Draw> cur(static_cast<std::size_t>(batch)), next(static_cast<std::size_t>(batch));
  int since_best = 0;
  int it = 0;
  // the first batch; then each next batch is drawn while the one before is scored (below)
  int m = it < o.max_iterations && since_best < o.patience ? std::min(batch, o.max_iterations - it) : 0;
  for (int k = 0; k < m; ++k) draw(cur[static_cast<std::size_t>(k)]);
  while (m > 0) {
    // Score this batch, each against the best before it (a looser limit than the sequential one, so
    // no hypothesis that could win is cut short), on all threads; meanwhile one of them draws the
    // next batch. The draws use only the random stream, in the sequential order, so the result is
    // the one-at-a-time result (the draws were serial and half of CTC-02's RANSAC time).
    const int m_next = std::min(batch, o.max_iterations - it - m);
    const double limit = best.cost;
#pragma omp parallel
#pragma omp single
    {
      if (m_next > 0) {
#pragma omp task
        for (int k = 0; k < m_next; ++k) draw(next[static_cast<std::size_t>(k)]);
      }
      for (int k = 0; k < m; ++k) {
        Draw* d = &cur[static_cast<std::size_t>(k)];
        if (!d->ok) continue;
#pragma omp task firstprivate(d)
        d->cost = cost(d->H, limit);
      }
    }
    // ... and take them in order, with the stopping rule as if one at a time
    bool stop = false;
    for (int k = 0; k < m; ++k, ++it) {
      if (since_best >= o.patience || ((it & 63) == 0 && cancelled && cancelled())) {
        stop = true;
        break;
      }
      ++best.iterations;
      ++since_best;
      const Draw& d = cur[static_cast<std::size_t>(k)];
      if (!d.ok) continue;
      if (d.affine) ++best.affine_samples;
      if (d.cost < best.cost) {
        best.cost = d.cost;
        best.H = d.H;
        best.found = true;
        best.sample = d.sample;
        best.improvements.emplace_back(it, d.cost);
        since_best = 0;
      }
    }
    if (stop || !(it < o.max_iterations && since_best < o.patience)) break;
    cur.swap(next);
    m = m_next;
  }
  return best;
}

}  // namespace fe
