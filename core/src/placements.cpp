// One-pair placements (placements.h).
#include "placements.h"

#include "featureextract/geometry.h"

#include <algorithm>
#include <utility>

namespace fe {

Placement one_pair_placement(const std::vector<KeyPointPair>& pairs, const Points& rp, const Points& tp,
                             const std::vector<double>& scales, const PairFrames& frames, const HypothesisScorer& scorer) {
  Placement out;
  const Eigen::Vector3d flips[4] = {{1, 1, 1}, {-1, -1, 1}, {-1, 1, -1}, {1, -1, -1}};
  const std::size_t stride = std::max<std::size_t>(1, pairs.size() / 1500);
  // (on all threads: each placement's slot is its own, and they are gathered in order)
  const std::size_t m = (pairs.size() + stride - 1) / stride;
  std::vector<double> q4(4 * m, INFINITY);
  std::vector<Eigen::Matrix4d> h4(4 * m);
#pragma omp parallel for schedule(dynamic, 16)
  for (std::size_t k = 0; k < m; ++k) {
    const std::size_t i = k * stride;
    const Eigen::Matrix3d fr = frames.ref(pairs[i]), ft = frames.tgt(pairs[i]);
    if (!fr.allFinite() || !ft.allFinite()) continue;
    for (int f = 0; f < 4; ++f) {
      const Eigen::Matrix3d lin = scales[i] * ft.transpose() * flips[f].asDiagonal() * fr;
      Eigen::Matrix4d& Hc = h4[4 * k + static_cast<std::size_t>(f)];
      Hc.setIdentity();
      Hc.topLeftCorner<3, 3>() = lin;
      Hc.topRightCorner<3, 1>() = tp.row(static_cast<Eigen::Index>(i)).transpose() - lin * rp.row(static_cast<Eigen::Index>(i)).transpose();
      q4[4 * k + static_cast<std::size_t>(f)] = scorer.screen_cost(Hc, scales[i]);
    }
  }
  std::vector<std::pair<double, Eigen::Matrix4d>> screened;
  for (std::size_t k = 0; k < 4 * m; ++k)
    if (std::isfinite(q4[k])) screened.emplace_back(q4[k] + 1e-12 * static_cast<double>((k / 4) * stride), h4[k]);
  const std::size_t keep = std::min<std::size_t>(screened.size(), 24);
  std::partial_sort(screened.begin(), screened.begin() + static_cast<long>(keep), screened.end(),
                    [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::size_t k = 0; k < keep; ++k) {
    const double c = scorer.cost(screened[k].second, out.cost);
    if (c < out.cost) { out.cost = c; out.H = screened[k].second; }
  }
  if (std::isfinite(out.cost)) {  // the pair whose target point lies nearest the mapped one
    double best = INFINITY;
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      const double d = (apply_transform(out.H, rp.row(static_cast<Eigen::Index>(i)).transpose()) - tp.row(static_cast<Eigen::Index>(i)).transpose()).norm();
      if (d < best) { best = d; out.pair = static_cast<int>(i); }
    }
  }
  return out;
}

}  // namespace fe
