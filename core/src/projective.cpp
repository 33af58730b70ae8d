// Step 6 (paper 3.8): the 4x4 projective transform with h44 = 1 from key point pairs.
#include "featureextract/geometry.h"

#include <Eigen/Dense>
#include <cmath>

namespace fe {

namespace {

// Similarity that maps points to mean 0 and RMS coordinate 1 (paper 3.7's normalization, isotropic
// so that the shape of the point set is kept).
Eigen::Matrix4d normalizer(const Points& p) {
  const Eigen::Vector3d mean = p.colwise().mean();
  const double rms = std::sqrt((p.rowwise() - mean.transpose()).squaredNorm() / (3.0 * static_cast<double>(p.rows())));
  const double s = rms > 0 ? 1.0 / rms : 1.0;
  Eigen::Matrix4d T = Eigen::Matrix4d::Identity();
  T.topLeftCorner<3, 3>() *= s;
  T.topRightCorner<3, 1>() = -s * mean;
  return T;
}

Points transformed(const Eigen::Matrix4d& T, const Points& p) {
  Points q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) q.row(i) = (T.topLeftCorner<3, 3>() * p.row(i).transpose() + T.topRightCorner<3, 1>()).transpose();
  return q;
}

// Rows of eq. (3.3): for each pair (x -> y) and axis i: H_i . X - y_i (h41 x1 + h42 x2 + h43 x3) = y_i.
void build_system(const Points& x, const Points& y, Eigen::MatrixXd& A, Eigen::VectorXd& b) {
  const Eigen::Index n = x.rows();
  A.setZero(3 * n, 15);
  b.resize(3 * n);
  for (Eigen::Index k = 0; k < n; ++k)
    for (int i = 0; i < 3; ++i) {
      const Eigen::Index r = 3 * k + i;
      A.block<1, 3>(r, 4 * i) = x.row(k);
      A(r, 4 * i + 3) = 1.0;
      A.block<1, 3>(r, 12) = -y(k, i) * x.row(k);
      b(r) = y(k, i);
    }
}

bool finish(const Eigen::VectorXd& h, const Eigen::Matrix4d& Tr, const Eigen::Matrix4d& Tt, Eigen::Matrix4d& H) {
  if (!h.allFinite()) return false;
  Eigen::Matrix4d Hn;
  Hn << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8), h(9), h(10), h(11), h(12), h(13), h(14), 1.0;
  H = Tt.inverse() * Hn * Tr;  // eq. (3.4): back to the original coordinates
  if (!(std::abs(H(3, 3)) > 1e-12)) return false;
  H /= H(3, 3);
  return H.allFinite();
}

}  // namespace

Eigen::Vector3d apply_transform(const Eigen::Matrix4d& H, const Eigen::Vector3d& p) {
  const Eigen::Vector4d q = H * p.homogeneous();
  if (!(std::abs(q(3)) > 1e-12)) return Eigen::Vector3d::Constant(NAN);
  return q.head<3>() / q(3);
}

Eigen::Matrix3d transform_jacobian(const Eigen::Matrix4d& H, const Eigen::Vector3d& p) {
  const Eigen::Matrix3d A = H.topLeftCorner<3, 3>();
  const Eigen::Vector3d g = H.block<1, 3>(3, 0).transpose();
  const double w = g.dot(p) + H(3, 3);
  const Eigen::Vector3d f = (A * p + H.topRightCorner<3, 1>()) / w;
  return (A - f * g.transpose()) / w;
}

bool solve_projective_5(const Eigen::Matrix<double, 5, 3>& ref, const Eigen::Matrix<double, 5, 3>& tgt, Eigen::Matrix4d& H) {
  const Points r = ref, t = tgt;
  const Eigen::Matrix4d Tr = normalizer(r), Tt = normalizer(t);
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  build_system(transformed(Tr, r), transformed(Tt, t), A, b);
  Eigen::FullPivLU<Eigen::MatrixXd> lu(A);
  lu.setThreshold(1e-9);
  if (lu.rank() < 15) return false;
  return finish(lu.solve(b), Tr, Tt, H);
}

bool fit_projective(const Points& ref, const Points& tgt, Eigen::Matrix4d& H) {
  if (ref.rows() < 5 || ref.rows() != tgt.rows()) return false;
  const Eigen::Matrix4d Tr = normalizer(ref), Tt = normalizer(tgt);
  Eigen::MatrixXd A;
  Eigen::VectorXd b;
  build_system(transformed(Tr, ref), transformed(Tt, tgt), A, b);
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(A);
  qr.setThreshold(1e-9);
  if (qr.rank() < 15) return false;
  return finish(qr.solve(b), Tr, Tt, H);
}

bool fit_affine(const Points& ref, const Points& tgt, Eigen::Matrix4d& H) {
  if (ref.rows() < 4 || ref.rows() != tgt.rows()) return false;
  const Eigen::Matrix4d Tr = normalizer(ref), Tt = normalizer(tgt);
  const Points x = transformed(Tr, ref), y = transformed(Tt, tgt);
  Eigen::MatrixXd X(x.rows(), 4);
  X.leftCols<3>() = x;
  X.col(3).setOnes();
  Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(X);
  qr.setThreshold(1e-9);
  if (qr.rank() < 4) return false;
  const Eigen::MatrixXd M = qr.solve(Eigen::MatrixXd(y));  // 4 x 3
  Eigen::Matrix4d Hn = Eigen::Matrix4d::Identity();
  Hn.topRows<3>() = M.transpose();
  H = Tt.inverse() * Hn * Tr;
  H /= H(3, 3);
  return H.allFinite();
}

Deformation deformation(const Eigen::Matrix4d& H, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  Deformation d;
  const Eigen::Vector3d c = 0.5 * (lo + hi);
  const Eigen::Matrix3d A = H.topLeftCorner<3, 3>();
  const Eigen::Vector3d t = H.topRightCorner<3, 1>();
  const Eigen::Vector3d g = H.block<1, 3>(3, 0).transpose();
  const double w = g.dot(c) + H(3, 3);
  if (!(std::abs(w) > 1e-12)) {
    d.perspective = INFINITY;
    return d;
  }
  const Eigen::Vector3d f = (A * c + t) / w;
  const Eigen::Matrix3d J = (A - f * g.transpose()) / w;  // Jacobian of x -> (A x + t) / (g.x + h44)
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(J);
  d.scale_max = svd.singularValues()(0);
  d.scale_min = svd.singularValues()(2);
  const double det = J.determinant();
  d.volume_ratio = std::abs(det);
  d.reflection = det < 0;
  for (int k = 0; k < 8; ++k) {
    const Eigen::Vector3d p((k & 1) ? hi.x() : lo.x(), (k & 2) ? hi.y() : lo.y(), (k & 4) ? hi.z() : lo.z());
    const double wk = g.dot(p) + H(3, 3);
    d.perspective = std::max(d.perspective, std::abs(wk / w - 1.0));
  }
  return d;
}

}  // namespace fe
