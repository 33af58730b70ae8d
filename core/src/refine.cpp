// The surface refinement (refine.h).
#include "refine.h"

#include "featureextract/geometry.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <tuple>
#include <unordered_map>

namespace fe {

SurfaceRefinement::SurfaceRefinement(const ShapeDescription::Impl& R, const ShapeDescription::Impl& T, const Params& p,
                                     const HypothesisScorer& scorer)
    : R_(R), T_(T), p_(p), scorer_(scorer), L_(R.L) {
  const std::vector<Eigen::Index> rows = stride_subset(scorer.core_dense(), 800);  // rows of R.dense behind pts_
  pts_.resize(static_cast<Eigen::Index>(rows.size()), 3);
  nrm_.resize(pts_.rows(), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) {
    pts_.row(static_cast<Eigen::Index>(k)) = R.dense.points.row(rows[k]);
    nrm_.row(static_cast<Eigen::Index>(k)) = R.dense_normals.row(rows[k]);
  }
  if (scorer.whole_faces().reference)
    for (const Eigen::Index i : rows) face_.push_back(R.dense.face_ids(i));
  cell_ = R.dense_h * R.dense_h * static_cast<double>(scorer.core_dense().size()) / static_cast<double>(std::max<Eigen::Index>(1, pts_.rows()));
  sym_ = scorer.symmetry();  // detected on these samples (hypothesis.cpp)
  if (sym_.axisymmetric) {
    // Border samples: where another face begins, or where the surface ends (the tangential centroid
    // of the neighbours leaves the sample: half a disc puts it 0.42 r off, a whole one at 0).
    const double r = 2.0 * R.dense_h;
    std::vector<int> idx;
    std::vector<float> d2;
    std::vector<Eigen::Index> rows;
    for (const Eigen::Index i : scorer.core_dense()) {
      const Eigen::Vector3d x = R.dense.points.row(i), n = R.dense_normals.row(i);
      R.dense_tree->radius(x, r, idx, d2);
      bool edge = false;
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (const int j : idx) {
        edge = edge || R.dense.face_ids(j) != R.dense.face_ids(i);
        c += R.dense.points.row(j).transpose() - x;
      }
      if (!idx.empty()) c /= static_cast<double>(idx.size());
      if (edge || (c - c.dot(n) * n).norm() > 0.2 * r) rows.push_back(i);
    }
    border_.resize(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t k = 0; k < rows.size(); ++k) border_.row(static_cast<Eigen::Index>(k)) = R.dense.points.row(rows[k]);
  }
}

std::unique_ptr<KdTree3> SurfaceRefinement::target_border(const Eigen::Matrix4d& H, double s) const {
  if (border_.rows() == 0) return nullptr;
  std::vector<Eigen::Vector3d> mapped(static_cast<std::size_t>(border_.rows()));
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (Eigen::Index k = 0; k < border_.rows(); ++k) c += mapped[static_cast<std::size_t>(k)] = apply_transform(H, border_.row(k).transpose());
  c /= static_cast<double>(border_.rows());
  double reach = 0;
  for (const Eigen::Vector3d& y : mapped) reach = std::max(reach, (y - c).norm());
  std::vector<int> idx, near_idx;
  std::vector<float> d2, near_d2;
  T_.dense_tree->radius(c, reach + 0.1 * L_ * s, idx, d2);
  std::sort(idx.begin(), idx.end());
  std::vector<Eigen::Index> rows;
  for (const int j : idx) {
    T_.dense_tree->radius(T_.dense.points.row(j).transpose(), 1.5 * T_.dense_h, near_idx, near_d2);
    for (const int q : near_idx)
      if (T_.dense.face_ids(q) != T_.dense.face_ids(j)) {
        rows.push_back(j);
        break;
      }
  }
  if (rows.empty()) return nullptr;
  Points P(static_cast<Eigen::Index>(rows.size()), 3);
  for (std::size_t k = 0; k < rows.size(); ++k) P.row(static_cast<Eigen::Index>(k)) = T_.dense.points.row(rows[k]);
  return std::make_unique<KdTree3>(P);
}

double SurfaceRefinement::border_distance(const KdTree3& target_border, const Eigen::Matrix4d& H, double s) const {
  double sum = 0;
  for (Eigen::Index k = 0; k < border_.rows(); ++k) {
    double d2;
    if (target_border.nearest(apply_transform(H, border_.row(k).transpose()), &d2) < 0) return INFINITY;
    sum += std::min(std::sqrt(d2) / s, scorer_.normal_penalty());
  }
  return sum / static_cast<double>(std::max<Eigen::Index>(1, border_.rows()));
}

// Reverse pairs (issue 9): the refinement pulls reference samples onto the target, which a fit on
// part of a larger instance already satisfies (a rib stretched 2x fitted over half its length, a
// step smaller than the one it lies on). Target samples of the faces that whole reference faces land
// on pull the other way, onto the nearest mapped reference sample, so the fit grows to cover those
// faces, up to 4 times the mapped area.
double SurfaceRefinement::reverse_pairs(const Eigen::Matrix4d& H, double s, std::vector<Eigen::Vector3d>* ra,
                                        std::vector<Eigen::Vector3d>* rb) const {
  if (face_.size() != static_cast<std::size_t>(pts_.rows())) return 0;
  std::unordered_map<int, std::vector<int>> on;  // target face -> refine points landing on it
  std::vector<char> wanted(scorer_.whole_faces().target_area.size(), 0);
  std::vector<Eigen::Vector3d> mapped(face_.size());
  const double land = 2 * T_.dense_h + 0.01 * L_ * s;
  for (std::size_t k = 0; k < face_.size(); ++k) {
    mapped[k] = apply_transform(H, pts_.row(static_cast<Eigen::Index>(k)).transpose());
    int j;
    if (!(scorer_.target_distance(mapped[k], &j) <= land) || j < 0) continue;
    const int g = T_.dense.face_ids(j);
    if (g <= 0 || static_cast<std::size_t>(g) >= wanted.size()) continue;
    on[g].push_back(static_cast<int>(k));
    const int f = face_[k];
    if (f > 0 && static_cast<std::size_t>(f) < scorer_.whole_faces().checked.size() && scorer_.whole_faces().checked[static_cast<std::size_t>(f)]) wanted[static_cast<std::size_t>(g)] = 1;
  }
  double sum = 0;
  int n = 0;
  for (const auto& [g, ks] : on) {
    if (!wanted[static_cast<std::size_t>(g)]) continue;
    const double mapped_area = static_cast<double>(ks.size()) * cell_ * s * s;
    if (scorer_.whole_faces().target_area[static_cast<std::size_t>(g)] > 4 * mapped_area) continue;  // not this feature's face
    for (const int t : scorer_.target_face_samples()[static_cast<std::size_t>(g)]) {
      const Eigen::Vector3d y = T_.dense.points.row(t).transpose();
      double best = INFINITY;
      int bk = -1;
      for (const int k : ks) {
        const double d = (mapped[static_cast<std::size_t>(k)] - y).squaredNorm();
        if (d < best) { best = d; bk = k; }
      }
      sum += std::min(std::sqrt(best) / s, scorer_.normal_penalty());
      ++n;
      if (ra && bk >= 0) {
        ra->push_back(pts_.row(bk).transpose());
        rb->push_back(y);
      }
    }
  }
  return n ? sum / n : 0.0;
}

SurfaceRefinement::Refined SurfaceRefinement::refine(const Eigen::Matrix4d& H0, double s0, bool grow) const {
  Eigen::Matrix4d H = H0;
  double s = s0;
  double c0 = scorer_.cost(H);
  double r0 = grow ? reverse_pairs(H, s, nullptr, nullptr) : 0.0;
  const double r_start = r0;
  const double search_radius = 0.25 * L_;
  for (int iter = 0; iter < p_.refine_iterations && std::isfinite(c0); ++iter) {
    // foot points on all threads, each in its own slot, gathered in order
    const std::size_t nr = static_cast<std::size_t>(pts_.rows());
    std::vector<Eigen::Vector3d> fa(nr), fb(nr);
    std::vector<double> fe(nr, -1.0);  // < 0: no foot point
#pragma omp parallel for schedule(dynamic, 32)
    for (std::size_t k = 0; k < nr; ++k) {
      const Eigen::Vector3d x = pts_.row(static_cast<Eigen::Index>(k));
      const Eigen::Vector3d y = apply_transform(H, x);
      // nearest target sample whose normal agrees (so the ends of a shortened rib find its end
      // faces instead of being dropped, and pull the fit out to full length)
      const Eigen::Vector3d nm = (transform_jacobian(H, x).inverse().transpose() * nrm_.row(static_cast<Eigen::Index>(k)).transpose()).normalized();
      double d2;
      int j = T_.dense_tree->nearest(y, &d2);
      if (j < 0) continue;
      if (nm.dot(T_.dense_normals.row(j)) < 0.5) {
        thread_local std::vector<int> near_idx;
        thread_local std::vector<float> near_d2;
        T_.dense_tree->radius(y, search_radius * s, near_idx, near_d2);
        j = -1;
        d2 = INFINITY;
        for (std::size_t c = 0; c < near_idx.size(); ++c)
          if (near_d2[c] < d2 && nm.dot(T_.dense_normals.row(near_idx[c])) >= 0.5) { j = near_idx[c]; d2 = near_d2[c]; }
        if (j < 0) continue;
      }
      const Eigen::Vector3d q = T_.dense.points.row(j), n = T_.dense_normals.row(j);
      fa[k] = x;
      fb[k] = y - (y - q).dot(n) * n;
      fe[k] = std::sqrt(d2);
    }
    std::vector<Eigen::Vector3d> a, b;
    std::vector<double> e;
    for (std::size_t k = 0; k < nr; ++k)
      if (fe[k] >= 0) {
        a.push_back(fa[k]);
        b.push_back(fb[k]);
        e.push_back(fe[k]);
      }
    if (a.size() < 20) break;
    std::vector<double> sorted = e;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
    const double cut = std::max(3.0 * sorted[sorted.size() / 2], 2.0 * T_.dense_h);
    Points A(static_cast<Eigen::Index>(a.size()), 3), B(static_cast<Eigen::Index>(a.size()), 3);
    Eigen::Index n = 0;
    for (std::size_t k = 0; k < a.size(); ++k)
      if (e[k] <= cut) { A.row(n) = a[k]; B.row(n++) = b[k]; }
    std::vector<Eigen::Vector3d> ra, rb;
    if (r0 > 0) reverse_pairs(H, s, &ra, &rb);
    // as much weight as the forward pairs (which hold a planar face in place but let it slide)
    const int copies = ra.empty() ? 0 : std::max<int>(1, static_cast<int>(std::lround(static_cast<double>(n) / static_cast<double>(ra.size()))));
    A.conservativeResize(n + copies * static_cast<Eigen::Index>(ra.size()), 3);
    B.conservativeResize(A.rows(), 3);
    for (int c = 0; c < copies; ++c)
      for (std::size_t k = 0; k < ra.size(); ++k) {
        A.row(n) = ra[k].transpose();
        B.row(n++) = rb[k].transpose();
      }
    Eigen::Matrix4d H2;
    bool ok = n >= 20 && fit_projective(A, B, H2) && scorer_.bounds_ok(H2, nullptr);
    if (!ok) ok = n >= 20 && fit_affine(A, B, H2) && scorer_.bounds_ok(H2, nullptr);
    if (!ok) break;
    const double c1 = scorer_.cost(H2);
    double s2 = s;
    scorer_.bounds_ok(H2, &s2);
    const double r1 = r0 > 0 ? reverse_pairs(H2, s2, nullptr, nullptr) : 0.0;
    if (!(c1 + r1 < c0 + r0)) break;
    H = H2;
    if (grow) s = s2;
    c0 = c1;
    r0 = r1;
  }
  return {H, s, c0, r_start, r0};
}

Polished SurfaceRefinement::polish(const Eigen::Matrix4d& H0, double cost0, const Points& rp, const Points& tp) const {
  Eigen::Matrix4d H = H0;
  double s = 1;
  scorer_.bounds_ok(H, &s);
  // Least-squares refit on the pairs consistent with H (keeps it only if the error does not grow).
  {
    const double tol = p_.accept_error * L_ * s;
    std::vector<Eigen::Index> in;
    for (Eigen::Index i = 0; i < rp.rows(); ++i)
      if ((apply_transform(H, rp.row(i).transpose()) - tp.row(i).transpose()).norm() <= tol) in.push_back(i);
    if (in.size() >= 6) {
      Points a(static_cast<Eigen::Index>(in.size()), 3), b(static_cast<Eigen::Index>(in.size()), 3);
      for (std::size_t k = 0; k < in.size(); ++k) {
        a.row(static_cast<Eigen::Index>(k)) = rp.row(in[k]);
        b.row(static_cast<Eigen::Index>(k)) = tp.row(in[k]);
      }
      Eigen::Matrix4d H2;
      if (fit_projective(a, b, H2) && scorer_.cost(H2) <= cost0) {
        H = H2;
        scorer_.bounds_ok(H, &s);
      }
    }
  }
  // Surface refinement (ICP-like): reference dense samples -> foot points on the target's tangent
  // planes, trimmed, projective least squares (affine if that leaves the bounds); kept while the
  // error decreases, and as a whole only if the RMS fit error did not grow.
  const Eigen::Matrix4d H_unrefined = H;
  const double rms_unrefined = scorer_.rms_on_surface(H);
  {
    const Refined tight = refine(H, s, false);
    Refined chosen_fit = tight;
    if (!face_.empty()) {
      // grown over whole faces: kept if its acceptance error stays within 0.4 of the bound (FTC-10's
      // far ear grew from 0.045 to 0.061 L), or near the tight fit's
      const Refined grown = refine(H, s, true);
      if (grown.reverse < 0.8 * grown.reverse_start) {
        const double eg = scorer_.quantile_error(grown.H), et = scorer_.quantile_error(tight.H);
        if (std::getenv("FE_DEBUG")) std::fprintf(stderr, "   grown: error/L %.4f (tight %.4f), reverse %.4f -> %.4f\n", eg / L_, et / L_, grown.reverse_start, grown.reverse);
        if (eg <= std::max(1.1 * et, 0.4 * p_.accept_error * L_)) chosen_fit = grown;
      }
    }
    H = chosen_fit.H;
    s = chosen_fit.s;
    const bool grew = chosen_fit.reverse < 0.8 * chosen_fit.reverse_start;
    double rh = scorer_.rms_on_surface(H);  // RMS of the current H, kept up to date below
    // (a fit grown over whole faces lies a little less tightly on them: its error was checked)
    if (!grew && rh > rms_unrefined) {
      H = H_unrefined;
      rh = rms_unrefined;
    }
    if (sym_.axisymmetric) {
      // The symmetric model fit, preferred unless clearly worse: a general projective map can
      // lower the RMS a little by skewing a boss, which the symmetric model (3 parameters on the
      // target's own axis) cannot.
      scorer_.bounds_ok(H, &s);
      const Eigen::Matrix4d Ha = fit_axisymmetric(H, sym_, pts_, nrm_, T_, L_ * s);
      if (!Ha.isApprox(H) && scorer_.bounds_ok(Ha, nullptr)) {
        const double ra = scorer_.rms_on_surface(Ha);
        if (ra <= std::max(1.25 * rh, rh + 0.002 * L_ * s)) {
          H = Ha;
          rh = ra;
        }
      }
      // The spin about the axis. A reference can be detected axisymmetric and be so only nearly
      // (NIST CTC-02's lug: a disc cut by its wall 26 mm from the bolt hole, whose top face and
      // cylinders are all about the axis): the spin is searched, every 10 degrees, then every 1 about
      // the best. Untwisting alone turned three of CTC-02's lugs 65-113 degrees.
      // The surface's RMS hardly sees the spin there (flat within sampling noise over 30-40 degrees:
      // lugs came out 8-15 degrees turned), the borders do: of the spins that fit the surface about as
      // well as the best (within 25 % or 0.001 L), the one whose border lies on the target's face
      // borders (the lug's root edge on its root). Without target face borders (a mesh), the RMS.
      // The least twisted spin is taken where it does as well as the best, within 5 % or 0.001 L of
      // sampling noise (a boss: every spin alike). The turns are measured on a third of the samples
      // (500): the RMS only has to tell which turns are within 25 % of the best, and the 54 turns
      // were most of the refinement's time (CTC-02: 6.1 of the matching stage's 11.0 s); the
      // untwisted spin is compared with the best on all of them.
      scorer_.bounds_ok(H, &s);
      const std::unique_ptr<KdTree3> tb = target_border(H, s);
      std::vector<std::tuple<double, double, double>> tried;  // (theta, rms, border)
      auto try_spin = [&](double theta) {
        const Eigen::Matrix4d Hs = spin(H, sym_, theta);
        if (!scorer_.bounds_ok(Hs, nullptr)) return;
        tried.emplace_back(theta, scorer_.rms_on_surface(Hs, true), tb ? border_distance(*tb, Hs, s) : 0.0);
      };
      const double noise = 0.001 * L_ * s;
      auto best_of = [&](double* theta, double* border) {
        double low = INFINITY, key_best = INFINITY;
        for (const auto& t : tried) low = std::min(low, std::get<1>(t));
        for (const auto& [th, r, b] : tried) {
          if (r > std::max(1.25 * low, low + noise)) continue;
          const double key = tb ? b : r;
          if (key < key_best - 1e-12 * L_) key_best = key, *theta = th, *border = b;
        }
      };
      constexpr double deg = EIGEN_PI / 180.0;
      for (int k = 0; k < 36; ++k) try_spin(10.0 * k * deg);
      double coarse = 0, best_border = 0;
      best_of(&coarse, &best_border);
      for (int k = -9; k <= 9; ++k)
        if (k != 0) try_spin(coarse + k * deg);
      double best_theta = 0;
      best_of(&best_theta, &best_border);
      const Eigen::Matrix4d Hu = untwist(H, sym_);
      // (on all the samples: the untwisted spin is kept when it does as well as the best within 5 %,
      // a margin finer than the coarse samples' noise on a round feature)
      const double best_full = best_theta == 0 ? rh : scorer_.rms_on_surface(spin(H, sym_, best_theta));
      bool keep_untwisted = scorer_.bounds_ok(Hu, nullptr) && scorer_.rms_on_surface(Hu) <= best_full + std::max(0.05 * best_full, noise);
      if (keep_untwisted && tb) keep_untwisted = border_distance(*tb, Hu, s) <= best_border + std::max(0.05 * best_border, noise);
      if (keep_untwisted) {
        H = Hu;
      } else if (best_theta != 0) {
        H = spin(H, sym_, best_theta);
        rh = best_full;
      }
    }
    scorer_.bounds_ok(H, &s);
  }
  Polished out;
  out.H = H;
  out.s = s;
  out.rms_unrefined = rms_unrefined;
  // judged with the reverse term too, so that a fit grown over whole faces is not passed over
  // for one that lies on part of them
  out.cost = scorer_.cost(H) + (face_.empty() ? 0.0 : reverse_pairs(H, s, nullptr, nullptr));
  return out;
}

}  // namespace fe
