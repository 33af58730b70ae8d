// Free space in front of a reference's surface (see clearance.h).
#include "featureextract/clearance.h"

#include "featureextract/geometry.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace fe {

Clearance::Clearance(const Points& points, const Points& normals, const std::vector<Eigen::Index>& rows, const Distance& reference_distance,
                     const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double step, double margin)
    : step_(step) {
  if (!(step > 0)) return;
  const Eigen::Vector3d blo = lo.array() - margin, bhi = hi.array() + margin;
  const double start = 3 * step;  // off the reference's own surface
  for (const Eigen::Index i : rows) {
    const Eigen::Vector3d o = points.row(i).transpose();
    const Eigen::Vector3d n = normals.row(i).transpose();
    if (!o.allFinite() || !(n.norm() > 0.5)) continue;
    const Eigen::Vector3d d = n.normalized();
    double t = start;
    for (;; t += step) {
      const Eigen::Vector3d x = o + t * d;
      if ((x.array() < blo.array()).any() || (x.array() > bhi.array()).any()) break;
      if (reference_distance(x) < 1.5 * step) break;
    }
    // the last stretch before the reference is met again is left out: the target surface may lie
    // there within the sampling of either surface
    const double free = t - 2 * step;
    if (free > start) rays_.push_back({o, d, free});
  }
}

double Clearance::obstructed(const Eigen::Matrix4d& H, const Distance& target_distance, double target_hit, double skip) const {
  if (rays_.empty()) return 0;
  int blocked = 0, checked = 0;
  const double start = std::max(3 * step_, skip);
  for (const Ray& r : rays_) {
    if (r.free <= start) continue;
    ++checked;
    for (double t = start; t <= r.free; t += step_) {
      const Eigen::Vector3d y = apply_transform(H, r.origin + t * r.direction);
      if (!y.allFinite()) break;
      if (target_distance(y) < target_hit) {
        ++blocked;
        break;
      }
    }
  }
  return checked ? static_cast<double>(blocked) / checked : 0.0;
}

double FaceCoverCheck::partial_share(const Eigen::Matrix4d& H, double tol, double fill) const {
  if (!reference || !target_faces || !target_nearest || target_area.empty()) return 0;
  const Samples& R = *reference;
  std::unordered_map<int, double> mapped_area;  // target face -> mapped reference area on it
  std::vector<int> lands(rows.size(), 0);       // target face each row lands on (0: none)
  const double cell = reference_spacing * reference_spacing;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const Eigen::Index i = rows[k];
    const Eigen::Vector3d x = R.points.row(i).transpose();
    const Eigen::Vector3d y = apply_transform(H, x);
    double d;
    const int j = target_nearest(y, &d);
    if (j < 0 || !(d <= tol)) continue;
    const int g = (*target_faces)(j);
    if (g <= 0 || static_cast<std::size_t>(g) >= target_area.size()) continue;
    const Eigen::Matrix3d J = transform_jacobian(H, x);
    const Eigen::Vector3d n = R.normals.row(i).transpose();
    const double a = std::abs(J.determinant()) * (J.inverse().transpose() * n).norm();  // Nanson: dA' = det J |J^-T n| dA
    if (!std::isfinite(a)) continue;
    mapped_area[g] += a * cell;
    lands[k] = g;
  }
  int checked_rows = 0, partial = 0;
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const int f = R.face_ids.size() ? R.face_ids(rows[k]) : 0;
    if (f <= 0 || static_cast<std::size_t>(f) >= checked.size() || !checked[static_cast<std::size_t>(f)] || lands[k] == 0) continue;
    ++checked_rows;
    if (mapped_area[lands[k]] < fill * target_area[static_cast<std::size_t>(lands[k])]) ++partial;
  }
  return checked_rows ? static_cast<double>(partial) / checked_rows : 0.0;
}

}  // namespace fe
