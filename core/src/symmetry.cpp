// Symmetry detection and the symmetric fit (symmetry.h).
#include "symmetry.h"

#include "featureextract/geometry.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <vector>

namespace fe {

// Axisymmetry of the reference (issue 5): on a surface of revolution every normal line meets the
// axis, so the Pluecker coordinates (n, x x n) of all normal lines satisfy one linear equation
// a.(x x n) + m.n = 0 with (a, m) the axis line. The smallest singular vector of that system gives
// the axis; its residual (a distance) says how well it holds. Planes alone (all normals parallel)
// are excluded: some normals must turn around the axis.
Symmetry detect_axisymmetry(const Points& x, const Points& n, double L) {
  Symmetry sym;
  if (x.rows() < 20) return sym;
  const Eigen::Vector3d c = x.colwise().mean().transpose();
  Eigen::Matrix<double, 6, 6> M = Eigen::Matrix<double, 6, 6>::Zero();
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    const Eigen::Vector3d xi = (x.row(i).transpose() - c) / L, ni = n.row(i).transpose();
    Eigen::Matrix<double, 6, 1> r;
    r << xi.cross(ni), ni;
    M += r * r.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(M);
  const Eigen::Matrix<double, 6, 1> v = es.eigenvectors().col(0);
  const Eigen::Vector3d a = v.head<3>(), m = v.tail<3>();
  if (a.norm() < 1e-6) return sym;
  // the line {p : p x a = m'} with moment m' = -m (sign of the equation above), normalized
  const Eigen::Vector3d dir = a.normalized();
  const Eigen::Vector3d moment = -m / a.norm();
  sym.axis = dir;
  sym.point = c + L * dir.cross(moment);  // closest point of the axis to the centroid
  // The algebraic fit weighs rows by their moment; refine the axis point geometrically: each normal
  // line lies in a plane with the axis, so (x - p).(a x n) = 0; rows normalized, trimmed twice.
  std::vector<double> res(static_cast<std::size_t>(x.rows()));
  for (int pass = 0; pass < 3; ++pass) {
    const Eigen::Vector3d u0 = dir.unitOrthogonal(), w0 = dir.cross(u0);
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
      const Eigen::Vector3d k = dir.cross(n.row(i).transpose());
      res[static_cast<std::size_t>(i)] = k.norm() > 0.2 ? std::abs((x.row(i).transpose() - sym.point).dot(k.normalized())) : -1;
    }
    std::vector<double> valid;
    for (double r : res) if (r >= 0) valid.push_back(r);
    if (valid.size() < 10) return sym;
    std::nth_element(valid.begin(), valid.begin() + static_cast<long>(valid.size() * 8 / 10), valid.end());
    const double cut = std::max(valid[valid.size() * 8 / 10], 1e-9 * L);
    Eigen::Matrix2d N = Eigen::Matrix2d::Zero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
      if (res[static_cast<std::size_t>(i)] < 0 || res[static_cast<std::size_t>(i)] > cut) continue;
      const Eigen::Vector3d k = dir.cross(n.row(i).transpose()).normalized();
      const Eigen::Vector2d row(k.dot(u0), k.dot(w0));  // k is orthogonal to dir: p moves in the plane
      N += row * row.transpose();
      rhs += row * (x.row(i).transpose() - sym.point).dot(k);
    }
    if (std::abs(N.determinant()) < 1e-12) return sym;
    const Eigen::Vector2d dp = N.ldlt().solve(rhs);
    sym.point += dp(0) * u0 + dp(1) * w0;
  }
  std::vector<double> dist;  // distances of the normal lines' planes from the final axis
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    const Eigen::Vector3d k = dir.cross(n.row(i).transpose());
    if (k.norm() > 0.2) dist.push_back(std::abs((x.row(i).transpose() - sym.point).dot(k.normalized())));
  }
  if (dist.empty()) return sym;
  std::nth_element(dist.begin(), dist.begin() + static_cast<long>(dist.size() / 2), dist.end());
  sym.residual = dist[dist.size() / 2];
  // normals must spread around the axis (not a single plane, not a single cylinder direction only)
  Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
  const Eigen::Vector3d u = dir.unitOrthogonal(), w = dir.cross(u);
  for (Eigen::Index i = 0; i < n.rows(); ++i) {
    const Eigen::Vector2d q(n.row(i).dot(u), n.row(i).dot(w));
    spread += q * q.transpose();
  }
  spread /= static_cast<double>(n.rows());
  const double lo = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(spread).eigenvalues()(0);
  sym.axisymmetric = sym.residual < 0.004 * L && lo > 0.05;
  return sym;
}


// For an axisymmetric reference the rotation about its axis is free: choose the one that makes the
// linear part of H twist least (maximal trace of A R), so that instances come out without an
// arbitrary spin and the same input always gives the same mesh orientation.
Eigen::Matrix4d untwist(const Eigen::Matrix4d& H, const Symmetry& sym) {
  const Eigen::Matrix3d A = transform_jacobian(H, sym.point);
  const Eigen::Vector3d a = sym.axis;
  Eigen::Matrix3d K;
  K << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - a * a.transpose();
  return spin(H, sym, std::atan2((A * K).trace(), (A * P).trace()));
}

Eigen::Matrix4d spin(const Eigen::Matrix4d& H, const Symmetry& sym, double theta) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(theta, sym.axis).toRotationMatrix();
  Eigen::Matrix4d G = Eigen::Matrix4d::Identity();
  G.topLeftCorner<3, 3>() = R;
  G.topRightCorner<3, 1>() = sym.point - R * sym.point;
  const Eigen::Matrix4d out = H * G;
  return out / out(3, 3);
}

// Axisymmetric references: RANSAC pairs contradict each other (any spin about the axis is as good),
// and a general projective fit can drift into a skewed map of a boss. This fit uses the symmetric
// model instead: the target's own axis (found the same way as the reference's, on the target samples
// around the current fit), then radial scale, axial scale and axial offset by point-to-plane least
// squares, a few ICP rounds. Returns H unchanged when the target axis cannot be found.
Eigen::Matrix4d fit_axisymmetric(const Eigen::Matrix4d& H, const Symmetry& rs, const Points& ref_pts, const Points& ref_nrm,
                                 const ShapeDescription::Impl& T, double size) {
  Points mapped(ref_pts.rows(), 3);
  for (Eigen::Index i = 0; i < ref_pts.rows(); ++i) mapped.row(i) = apply_transform(H, ref_pts.row(i).transpose());
  if (!mapped.allFinite()) return H;
  const Eigen::Vector3d lo = mapped.colwise().minCoeff().transpose() - Eigen::Vector3d::Constant(0.05 * size);
  const Eigen::Vector3d hi = mapped.colwise().maxCoeff().transpose() + Eigen::Vector3d::Constant(0.05 * size);
  std::vector<Eigen::Index> near;
  for (Eigen::Index j = 0; j < T.dense.points.rows(); ++j) {
    const Eigen::Vector3d q = T.dense.points.row(j);
    if ((q.array() >= lo.array()).all() && (q.array() <= hi.array()).all()) near.push_back(j);
  }
  if (near.size() < 50) return H;
  Points tp(static_cast<Eigen::Index>(near.size()), 3), tn(static_cast<Eigen::Index>(near.size()), 3);
  for (std::size_t k = 0; k < near.size(); ++k) {
    tp.row(static_cast<Eigen::Index>(k)) = T.dense.points.row(near[k]);
    tn.row(static_cast<Eigen::Index>(k)) = T.dense_normals.row(near[k]);
  }
  const Symmetry ts = detect_axisymmetry(tp, tn, size);
  if (std::getenv("FE_DEBUG")) std::fprintf(stderr, "debug: target axis residual %.4f (size %.2f) point %.2f %.2f %.2f dir %.3f %.3f %.3f\n", ts.residual, size, ts.point.x(), ts.point.y(), ts.point.z(), ts.axis.x(), ts.axis.y(), ts.axis.z());
  if (!(ts.residual < 0.01 * size)) return H;
  const Eigen::Vector3d ar = rs.axis, cr = rs.point;
  Eigen::Vector3d at = ts.axis;
  if ((transform_jacobian(H, cr) * ar).dot(at) < 0) at = -at;
  const Eigen::Matrix3d R = Eigen::Quaterniond::FromTwoVectors(ar, at).toRotationMatrix();
  // initial parameters from H
  const double s0 = std::cbrt(std::abs(transform_jacobian(H, cr).determinant()));
  double sr = s0, sa = s0, t = (apply_transform(H, cr) - ts.point).dot(at);
  auto model = [&](double r_, double a_, double t_) {
    Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
    const Eigen::Matrix3d lin = r_ * R * (Eigen::Matrix3d::Identity() - ar * ar.transpose()) + a_ * at * ar.transpose();
    M.topLeftCorner<3, 3>() = lin;
    M.topRightCorner<3, 1>() = ts.point + t_ * at - lin * cr;
    return M;
  };
  for (int iter = 0; iter < 10; ++iter) {
    const Eigen::Matrix4d M = model(sr, sa, t);
    std::vector<Eigen::Vector4d> rows;  // (d sr, d sa, d t | rhs)
    std::vector<double> err;
    for (Eigen::Index i = 0; i < ref_pts.rows(); ++i) {
      const Eigen::Vector3d x = ref_pts.row(i), d = x - cr;
      const double h = d.dot(ar);
      const Eigen::Vector3d rho = R * (d - h * ar);
      const Eigen::Vector3d y = apply_transform(M, x);
      const Eigen::Vector3d ny = (M.topLeftCorner<3, 3>().inverse().transpose() * ref_nrm.row(i).transpose()).normalized();
      double d2;
      const int j = T.dense_tree->nearest(y, &d2);
      if (j < 0 || ny.dot(T.dense_normals.row(j)) < 0.5) continue;
      const Eigen::Vector3d q = T.dense.points.row(j), n = T.dense_normals.row(j);
      rows.emplace_back(rho.dot(n), h * at.dot(n), at.dot(n), (q - ts.point).dot(n));
      err.push_back(std::sqrt(d2));
    }
    if (rows.size() < 30) return H;
    std::vector<double> sorted = err;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
    const double cut = std::max(3.0 * sorted[sorted.size() / 2], 1e-3 * size);
    Eigen::Matrix3d N = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < rows.size(); ++k) {
      if (err[k] > cut) continue;
      const Eigen::Vector3d g = rows[k].head<3>();
      N += g * g.transpose();
      b += g * rows[k](3);
    }
    // A weak pull toward the same scale along the axis as across it: where nothing on the target
    // fixes the axial scale (a counterbore picked as faces, both its cylinders running out at the
    // picked border: only the ring's height is fixed), the fit keeps the feature's proportions
    // instead of the scale it started from; where the surface fixes it, the pull is 1e-3 of the data.
    {
      const Eigen::Vector3d g(-1.0, 1.0, 0.0);
      N += 1e-3 * N.trace() / 3.0 * g * g.transpose();
    }
    const Eigen::Vector3d sol = N.ldlt().solve(b);
    if (!sol.allFinite() || sol(0) <= 0 || sol(1) <= 0) return H;
    const bool done = std::abs(sol(0) - sr) < 1e-6 * s0 && std::abs(sol(1) - sa) < 1e-6 * s0 && std::abs(sol(2) - t) < 1e-6 * size;
    sr = sol(0);
    sa = sol(1);
    t = sol(2);
    if (done) break;
  }
  if (std::getenv("FE_DEBUG")) std::fprintf(stderr, "debug: axisymmetric fit sr %.3f sa %.3f t %.3f\n", sr, sa, t);
  return model(sr, sa, t);
}

}  // namespace fe
