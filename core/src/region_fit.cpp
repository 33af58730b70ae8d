// Hypotheses for a reference that is one smooth region (region_fit.h).
#include "region_fit.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <array>
#include <cmath>
#include <numeric>

namespace fe {

RegionShape region_shape(const Points& x, const std::vector<Eigen::Index>& rows) {
  RegionShape s;
  const std::size_t n = rows.empty() ? static_cast<std::size_t>(x.rows()) : rows.size();
  s.samples = n;
  if (n == 0) return s;
  auto row = [&](std::size_t k) -> Eigen::Vector3d {
    return x.row(rows.empty() ? static_cast<Eigen::Index>(k) : rows[k]).transpose();
  };
  for (std::size_t k = 0; k < n; ++k) s.centroid += row(k);
  s.centroid /= static_cast<double>(n);
  Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
  for (std::size_t k = 0; k < n; ++k) {
    const Eigen::Vector3d d = row(k) - s.centroid;
    C += d * d.transpose();
  }
  C /= static_cast<double>(n);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
  // (ascending eigenvalues: reversed, so that the first axis is the longest)
  for (int i = 0; i < 3; ++i) {
    s.axes.col(i) = es.eigenvectors().col(2 - i);
    s.sigma(i) = std::sqrt(std::max(0.0, es.eigenvalues()(2 - i)));
  }
  // a deterministic sense for each axis (the eigen solver's is arbitrary): the larger component positive
  for (int i = 0; i < 3; ++i) {
    Eigen::Index k;
    s.axes.col(i).cwiseAbs().maxCoeff(&k);
    if (s.axes(k, i) < 0) s.axes.col(i) = -s.axes.col(i);
  }
  return s;
}

std::vector<RegionHypotheses> region_hypotheses(const RegionShape& ref, const std::vector<RegionShape>& targets,
                                                const RegionFitOptions& o) {
  std::vector<RegionHypotheses> out;
  if (ref.samples == 0 || !(ref.sigma(1) > 0)) return out;
  // A reference flat across its thinnest axis (a gently curved fin): that axis's ratio is not
  // measured, it follows the other two.
  constexpr double kFlat = 0.02, kAlike = 1.15;
  const bool ref_flat = ref.sigma(2) < kFlat * ref.sigma(0);
  const std::array<std::array<int, 3>, 6> perms{{{0, 1, 2}, {1, 0, 2}, {0, 2, 1}, {2, 1, 0}, {1, 2, 0}, {2, 0, 1}}};
  for (std::size_t t = 0; t < targets.size(); ++t) {
    const RegionShape& g = targets[t];
    if (g.samples < o.min_samples || !(g.sigma(1) > 0)) continue;
    const bool flat = ref_flat || g.sigma(2) < kFlat * g.sigma(0);
    auto alike = [](double a, double b) { return a <= kAlike * b && b <= kAlike * a; };
    RegionHypotheses rh;
    rh.region = static_cast<int>(t);
    rh.dissimilarity = INFINITY;
    for (const auto& pm : perms) {
      // axis i of the reference goes to axis pm[i] of the target; only where the extents leave the
      // order undefined (within 15 % of each other, on either side)
      bool allowed = true;
      for (int i = 0; i < 3; ++i)
        if (pm[static_cast<std::size_t>(i)] != i &&
            !(alike(g.sigma(i), g.sigma(pm[static_cast<std::size_t>(i)])) || alike(ref.sigma(i), ref.sigma(pm[static_cast<std::size_t>(i)]))))
          allowed = false;
      if (!allowed) continue;
      Eigen::Vector3d k;
      for (int i = 0; i < 2; ++i) k(i) = g.sigma(pm[static_cast<std::size_t>(i)]) / ref.sigma(i);
      k(2) = flat ? std::sqrt(k(0) * k(1)) : g.sigma(pm[2]) / ref.sigma(2);
      if (!(k.minCoeff() >= o.axis_scale_min && k.maxCoeff() <= o.axis_scale_max && k.maxCoeff() <= o.max_anisotropy * k.minCoeff()))
        continue;
      rh.dissimilarity = std::min(rh.dissimilarity, std::log(k.maxCoeff() / k.minCoeff()));
      for (int signs = 0; signs < 8; ++signs) {
        Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
        for (int i = 0; i < 3; ++i) {
          const double sg = (signs >> i) & 1 ? -1.0 : 1.0;
          A += sg * k(i) * g.axes.col(pm[static_cast<std::size_t>(i)]) * ref.axes.col(i).transpose();
        }
        if (!(A.determinant() > 0)) continue;
        Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
        H.topLeftCorner<3, 3>() = A;
        H.topRightCorner<3, 1>() = g.centroid - A * ref.centroid;
        rh.H.push_back(H);
      }
    }
    if (!rh.H.empty()) out.push_back(std::move(rh));
  }
  std::stable_sort(out.begin(), out.end(), [](const RegionHypotheses& a, const RegionHypotheses& b) { return a.dissimilarity < b.dissimilarity; });
  if (out.size() > o.max_regions) out.resize(o.max_regions);
  return out;
}

}  // namespace fe
