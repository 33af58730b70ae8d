// Free space in front of a reference's surface (see clearance.h).
#include "featureextract/clearance.h"

#include "featureextract/geometry.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

namespace fe {

Clearance::Clearance(const Points& points, const Points& normals, const std::vector<Eigen::Index>& rows, const Nearest& reference_nearest,
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
    Ray ray{o, d};
    for (;; t += step) {
      const Eigen::Vector3d x = o + t * d;
      if ((x.array() < blo.array()).any() || (x.array() > bhi.array()).any()) break;
      const Eigen::Vector3d q = reference_nearest(x);
      const double rd = q.allFinite() ? (q - x).norm() : INFINITY;
      if (rd < 1.5 * step) {
        ray.met = true;
        break;
      }
      if (t >= 2 * start && rd < ray.clear) {  // (past where its own face is the nearest)
        ray.clear = rd;
        ray.near_ray = x;
        ray.near_reference = q;
      }
    }
    // the last stretch before the reference is met again is left out: the target surface may lie
    // there within the sampling of either surface
    ray.free = t - 2 * step;
    ray.end = t;
    if (ray.free > start) rays_.push_back(ray);
  }
}

double Clearance::obstructed(const Eigen::Matrix4d& H, const Distance& target_distance, double target_hit, double skip) const {
  if (rays_.empty()) return 0;
  int blocked = 0, checked = 0;
  for (const Ray& r : rays_) {
    // The stretches left out at either end are meant at the map's scale s; along a direction the
    // map stretches by l instead (a pocket mapped 0.35x across, 1.3x deep), they are taken s / l
    // times as long, so that they keep their length on the target.
    const Eigen::Matrix3d J = transform_jacobian(H, r.origin);
    const double l = (J * r.direction).norm(), s = std::cbrt(std::abs(J.determinant()));
    const double k = l > 0 && s > 0 && std::isfinite(l) && std::isfinite(s) ? s / l : 1.0;
    const double start = std::max(3 * step_, skip) * k;
    // A ray that left the box runs on at least as far as the map's scale takes it: a step's open side
    // mapped onto a hexagonal passage's walls, squeezed 0.36x, must still reach the walls across.
    const double free = r.met ? r.end - 2 * step_ * k : (r.end - 2 * step_) * std::max(1.0, k);
    if (free <= start || r.free <= std::max(3 * step_, skip)) continue;
    // A ray that passes the reference's own surface closer than the target hit distance, once the map
    // has squeezed it (a floor's ray beside the walls of a pocket mapped 0.4x across), cannot tell
    // free space from that surface: it is not counted.
    if (std::isfinite(r.clear) && (apply_transform(H, r.near_ray) - apply_transform(H, r.near_reference)).norm() < target_hit) continue;
    ++checked;
    const double dt = step_ * std::min(1.0, k);
    for (double t = start; t <= free; t += dt) {
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
  std::map<std::pair<int, int>, bool> through;  // (reference face, target face) -> goes_on_through
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const int f = R.face_ids.size() ? R.face_ids(rows[k]) : 0;
    if (f <= 0 || static_cast<std::size_t>(f) >= checked.size() || !checked[static_cast<std::size_t>(f)] || lands[k] == 0) continue;
    ++checked_rows;
    if (mapped_area[lands[k]] < fill * target_area[static_cast<std::size_t>(lands[k])]) {
      if (goes_on_through) {
        const auto key = std::make_pair(f, lands[k]);
        auto it = through.find(key);
        if (it == through.end()) it = through.emplace(key, goes_on_through(H, f, lands[k])).first;
        if (it->second) continue;
      }
      ++partial;
    }
  }
  return checked_rows ? static_cast<double>(partial) / checked_rows : 0.0;
}

}  // namespace fe
