// Step 2 (paper 3.4) signed curvature and shape index; step 3 (3.5) key point test.
// PCL's PrincipalCurvaturesEstimation is unsigned (eigenvalues of projected-normal covariance) and
// cannot tell a cap from a cup, so the curvatures come from our own local quadric fit.
#include "curvature.h"

#include <Eigen/Dense>
#include <cmath>
#include <limits>

namespace fe {

namespace {
// An orthonormal tangent basis (u, v) for a unit normal n.
void tangent_frame(const Eigen::Vector3d& n, Eigen::Vector3d& u, Eigen::Vector3d& v) {
  const Eigen::Vector3d a = std::abs(n.x()) < 0.9 ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
  u = n.cross(a).normalized();
  v = n.cross(u);
}
}  // namespace

Points estimate_normals(const Samples& support, const Samples& query, double radius) {
  return estimate_normals(KdTree3(support.points), support, query, radius);
}

Points estimate_normals(const KdTree3& tree, const Samples& support, const Samples& query, double radius) {
  Points out(query.points.rows(), 3);
#pragma omp parallel
  {
    std::vector<int> idx;
    std::vector<float> d2;
#pragma omp for schedule(dynamic, 256)
    for (Eigen::Index i = 0; i < query.points.rows(); ++i) {
      const Eigen::Vector3d p = query.points.row(i);
      const Eigen::Vector3d raw = query.normals.row(i);
      tree.radius(p, radius, idx, d2);
      Eigen::Vector3d mean = Eigen::Vector3d::Zero();
      int n = 0;
      for (int j : idx)
        if (support.normals.row(j).dot(raw) > 0.0) { mean += support.points.row(j).transpose(); ++n; }
      if (n < 3) { out.row(i) = raw; continue; }
      mean /= n;
      Eigen::Matrix3d C = Eigen::Matrix3d::Zero();
      for (int j : idx)
        if (support.normals.row(j).dot(raw) > 0.0) {
          const Eigen::Vector3d d = support.points.row(j).transpose() - mean;
          C += d * d.transpose();
        }
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(C);
      Eigen::Vector3d nn = es.eigenvectors().col(0);
      if (nn.dot(raw) < 0) nn = -nn;
      out.row(i) = nn.allFinite() ? nn : raw;
    }
  }
  return out;
}

Eigen::MatrixX2d principal_curvatures(const Points& support, const Points& support_normals, const Points& query,
                                      const Points& query_normals, double radius) {
  return principal_curvatures(KdTree3(support), support, support_normals, query, query_normals, radius);
}

Eigen::MatrixX2d principal_curvatures(const KdTree3& tree, const Points& support, const Points& support_normals, const Points& query,
                                      const Points& query_normals, double radius) {
  Eigen::MatrixX2d out(query.rows(), 2);
#pragma omp parallel
  {
    std::vector<int> idx;
    std::vector<float> d2;
#pragma omp for schedule(dynamic, 256)
    for (Eigen::Index i = 0; i < query.rows(); ++i) {
      const Eigen::Vector3d p = query.row(i);
      const Eigen::Vector3d n = query_normals.row(i);
      Eigen::Vector3d u, v;
      tangent_frame(n, u, v);
      tree.radius(p, radius, idx, d2);
      Eigen::Matrix<double, 6, 6> AtA = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> Atb = Eigen::Matrix<double, 6, 1>::Zero();
      int count = 0;
      const double inv_r2 = 1.0 / (radius * radius);
      for (std::size_t k = 0; k < idx.size(); ++k) {
        const int j = idx[k];
        if (support_normals.row(j).dot(n) <= 0.2) continue;  // other skin of a thin wall, or across a sharp fold
        const Eigen::Vector3d d = support.row(j).transpose() - p;
        const double x = d.dot(u) / radius, y = d.dot(v) / radius, z = d.dot(n) / radius;  // scaled: conditioning
        const double w = 1.0 - 0.5 * d2[k] * inv_r2;
        Eigen::Matrix<double, 6, 1> a;
        a << x * x, x * y, y * y, x, y, 1.0;
        AtA += w * a * a.transpose();
        Atb += w * a * z;
        ++count;
      }
      if (count < 6) { out.row(i) << NAN, NAN; continue; }
      const Eigen::Matrix<double, 6, 1> c = AtA.ldlt().solve(Atb);
      // z = h(x, y); curvature at the origin from II / I with gradient (c3, c4). In the scaled
      // coordinates curvatures are multiplied by `radius`: undo that.
      const double hx = c(3), hy = c(4), hxx = 2 * c(0), hxy = c(1), hyy = 2 * c(2);
      const double g = 1 + hx * hx + hy * hy;
      Eigen::Matrix2d I, II;
      I << 1 + hx * hx, hx * hy, hx * hy, 1 + hy * hy;
      II << hxx, hxy, hxy, hyy;
      II /= std::sqrt(g);
      const Eigen::Matrix2d S = I.inverse() * II;  // shape operator (not symmetric in general)
      const double tr = S.trace(), det = S.determinant();
      const double disc = std::sqrt(std::max(0.0, tr * tr / 4 - det));
      out(i, 0) = (tr / 2 + disc) / radius;
      out(i, 1) = (tr / 2 - disc) / radius;
      if (!out.row(i).allFinite()) out.row(i) << NAN, NAN;
    }
  }
  return out;
}

double shape_index(double k1, double k2, double planar_curvedness) {
  if (!std::isfinite(k1) || !std::isfinite(k2)) return kPlanarShapeIndex;
  if (k1 < k2) std::swap(k1, k2);
  const double curvedness = std::sqrt(0.5 * (k1 * k1 + k2 * k2));
  if (curvedness < planar_curvedness) return kPlanarShapeIndex;
  // eq. (3.1) with atan2 so that umbilics (k1 == k2) are handled: caps (k < 0, outward normals) -> 1.
  return 0.5 - std::atan2(k1 + k2, k1 - k2) / M_PI;
}

bool is_key_shape_index(double si, double band) {
  if (si < 0) return false;                       // planar
  if (si >= kCreaseShapeIndex) si -= kCreaseShapeIndex;  // sharp creases: the same bands
  if (std::abs(si - 0.25) <= band) return false;  // rut
  if (std::abs(si - 0.75) <= band) return false;  // ridge
  return true;
}


Eigen::VectorXd crease_shape_index(const Samples& support, const Samples& query, double radius) {
  return crease_shape_index(KdTree3(support.points), support, query, radius);
}

Eigen::VectorXd crease_shape_index(const KdTree3& tree, const Samples& support, const Samples& query, double radius) {
  Eigen::VectorXd out = Eigen::VectorXd::Constant(query.points.rows(), std::numeric_limits<double>::quiet_NaN());
  const double turn = std::cos(30.0 * M_PI / 180.0), skin = std::cos(150.0 * M_PI / 180.0);
#pragma omp parallel
  {
    std::vector<int> idx;
    std::vector<float> d2;
#pragma omp for schedule(dynamic, 256)
    for (Eigen::Index i = 0; i < query.points.rows(); ++i) {
      const Eigen::Vector3d p = query.points.row(i), n = query.normals.row(i);
      tree.radius(p, radius, idx, d2);
      // support points on other facets: their raw normals turn by 30-150 degrees from this one's
      // (beyond 150: the other skin of a thin wall, not a crease). A crease is sharp: every support
      // normal is within 8 degrees of this facet's or of one of at most two other facets' (a
      // tessellated fillet sweeps through the angles between and is left to the quadric fit).
      const double tight = std::cos(8.0 * M_PI / 180.0);
      Eigen::Vector3d m1 = Eigen::Vector3d::Zero(), m2 = Eigen::Vector3d::Zero();
      double rise[2] = {0, 0};
      int count[2] = {0, 0}, loose = 0, all = 0;
      for (int j : idx) {
        const Eigen::Vector3d m = support.normals.row(j);
        const double c = m.dot(n);
        if (c < skin) continue;
        ++all;
        if (c > tight) continue;
        if (c > turn) { ++loose; continue; }
        if (m1.isZero()) m1 = m;
        int facet;
        if (m.dot(m1) > tight) facet = 0;
        else {
          if (m2.isZero() && m.dot(m1) < turn) m2 = m;
          if (m2.isZero() || m.dot(m2) <= tight) { ++loose; continue; }
          facet = 1;
        }
        rise[facet] += (support.points.row(j).transpose() - p).dot(n);
        ++count[facet];
      }
      if (loose > 0.1 * all) continue;
      if (count[0] < 2) continue;
      const bool convex0 = rise[0] < 0, convex1 = rise[1] < 0;
      // two other facets facing away from each other are the two edges of a thin strip, not a corner
      const bool corner = count[1] >= 2 && m1.dot(m2) > skin;
      if (!corner) {
        out(i) = rise[0] + rise[1] < 0 ? 0.75 : 0.25;  // an edge: ridge or rut
      } else {
        out(i) = convex0 && convex1 ? 1.0 : (!convex0 && !convex1 ? 0.0 : 0.5);  // a corner: cap, cup or saddle
      }
    }
  }
  return out;
}

}  // namespace fe
