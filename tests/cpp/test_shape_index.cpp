// Shape index of sampled analytic surfaces (issue 2 tests): caps, cups, ridges, ruts, saddles, planes.
#include "featureextract/geometry.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>

namespace {

// Samples a height field z = h(x, y) on a grid with upward (+z side) normals, optionally flipped.
struct Surface {
  fe::Points p, n;
};
Surface height_field(const std::function<double(double, double)>& h, double half, double step, bool flip) {
  std::vector<Eigen::Vector3d> pts, nrm;
  const double e = 1e-5;
  for (double x = -half; x <= half + 1e-9; x += step)
    for (double y = -half; y <= half + 1e-9; y += step) {
      const double z = h(x, y);
      const double hx = (h(x + e, y) - h(x - e, y)) / (2 * e), hy = (h(x, y + e) - h(x, y - e)) / (2 * e);
      Eigen::Vector3d n(-hx, -hy, 1.0);
      n.normalize();
      pts.emplace_back(x, y, z);
      nrm.push_back(flip ? Eigen::Vector3d(-n) : n);
    }
  Surface s;
  s.p.resize(static_cast<Eigen::Index>(pts.size()), 3);
  s.n.resize(s.p.rows(), 3);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    s.p.row(static_cast<Eigen::Index>(i)) = pts[i];
    s.n.row(static_cast<Eigen::Index>(i)) = nrm[i];
  }
  return s;
}

double si_at_origin(const Surface& s, double radius, double planar = 1e-3) {
  fe::Points q(1, 3), qn(1, 3);
  Eigen::Index best = 0;
  s.p.rowwise().squaredNorm().minCoeff(&best);  // the sample at the origin
  q.row(0) = s.p.row(best);
  qn.row(0) = s.n.row(best);
  const Eigen::MatrixX2d k = fe::principal_curvatures(s.p, s.n, q, qn, radius);
  return fe::shape_index(k(0, 0), k(0, 1), planar);
}

const double R = 10.0;
auto sphere_top = [](double x, double y) { return std::sqrt(std::max(0.0, R * R - x * x - y * y)) - R; };
auto cylinder_top = [](double x, double) { return std::sqrt(std::max(0.0, R * R - x * x)) - R; };

}  // namespace

TEST(ShapeIndex, SphereFromOutsideIsCap) {
  EXPECT_NEAR(si_at_origin(height_field(sphere_top, 3, 0.1, false), 1.5), 1.0, 0.05);
}

TEST(ShapeIndex, SphereFromInsideIsCup) {
  // The inside of a sphere: the same surface with normals pointing to the centre.
  EXPECT_NEAR(si_at_origin(height_field(sphere_top, 3, 0.1, true), 1.5), 0.0, 0.05);
}

TEST(ShapeIndex, CylinderOutsideIsRidgeInsideIsRut) {
  EXPECT_NEAR(si_at_origin(height_field(cylinder_top, 3, 0.1, false), 1.5), 0.75, 0.05);
  EXPECT_NEAR(si_at_origin(height_field(cylinder_top, 3, 0.1, true), 1.5), 0.25, 0.05);
}

TEST(ShapeIndex, SaddleIsHalf) {
  auto saddle = [](double x, double y) { return (x * x - y * y) / (2 * R); };
  EXPECT_NEAR(si_at_origin(height_field(saddle, 3, 0.1, false), 1.5), 0.5, 0.05);
}

TEST(ShapeIndex, PlaneGetsThePlanarValue) {
  auto plane = [](double x, double y) { return 0.2 * x - 0.1 * y; };
  EXPECT_EQ(si_at_origin(height_field(plane, 3, 0.1, false), 1.5), fe::kPlanarShapeIndex);
  // ... and so does a very gentle curve below the curvedness threshold
  auto gentle = [](double x, double y) { return (x * x + y * y) / 2000.0; };
  EXPECT_EQ(si_at_origin(height_field(gentle, 3, 0.1, false), 1.5, 0.01), fe::kPlanarShapeIndex);
}

TEST(ShapeIndex, CurvatureMagnitudeIsRight) {
  const Surface s = height_field(sphere_top, 3, 0.1, false);
  fe::Points q(1, 3), qn(1, 3);
  Eigen::Index best = 0;
  s.p.rowwise().squaredNorm().minCoeff(&best);
  q.row(0) = s.p.row(best);
  qn.row(0) = s.n.row(best);
  const Eigen::MatrixX2d k = fe::principal_curvatures(s.p, s.n, q, qn, 1.5);
  EXPECT_NEAR(k(0, 0), -1.0 / R, 0.01);  // outward normals: convex curvature is negative
  EXPECT_NEAR(k(0, 1), -1.0 / R, 0.01);
}

TEST(ShapeIndex, KeyPointBands) {
  EXPECT_FALSE(fe::is_key_shape_index(fe::kPlanarShapeIndex, 0.07));
  EXPECT_FALSE(fe::is_key_shape_index(0.25, 0.07));  // rut
  EXPECT_FALSE(fe::is_key_shape_index(0.78, 0.07));  // ridge
  EXPECT_TRUE(fe::is_key_shape_index(1.0, 0.07));    // cap
  EXPECT_TRUE(fe::is_key_shape_index(0.0, 0.07));    // cup
  EXPECT_TRUE(fe::is_key_shape_index(0.5, 0.07));    // saddle
}

TEST(Sampling, UniformAndDeterministic) {
  fe::TriangleMesh m;
  m.vertices.resize(4, 3);
  m.vertices << 0, 0, 0, 10, 0, 0, 10, 10, 0, 0, 10, 0;
  m.triangles.resize(2, 3);
  m.triangles << 0, 1, 2, 0, 2, 3;
  m.face_ids = Eigen::VectorXi::Constant(2, 1);
  const fe::Samples a = fe::sample_surface(m, 0.5, 7), b = fe::sample_surface(m, 0.5, 7);
  ASSERT_EQ(a.size(), b.size());
  EXPECT_TRUE(a.points.isApprox(b.points));
  // one sample per 0.5 x 0.5 cell of a 10 x 10 square: about 400
  EXPECT_GT(a.size(), 360u);
  EXPECT_LE(a.size(), 400u);
  EXPECT_TRUE((a.normals.col(2).array() > 0.99).all());
  EXPECT_TRUE((a.face_ids.array() == 1).all());
}
