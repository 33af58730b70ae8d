// Acceptance checks on what surrounds a hypothesis (clearance.h): free space in front of the
// reference, and whole faces. Synthetic samples, so that each check is seen alone.
#include "featureextract/clearance.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

namespace {

struct Cloud {
  std::vector<Eigen::Vector3d> p, n;
  std::vector<int> face;
  // a grid of samples at spacing h over the rectangle o + [0,1]u x [0,1]v (u, v with lengths)
  void rect(const Eigen::Vector3d& o, const Eigen::Vector3d& u, const Eigen::Vector3d& v, const Eigen::Vector3d& normal, int f, double h) {
    const int nu = static_cast<int>(std::round(u.norm() / h)), nv = static_cast<int>(std::round(v.norm() / h));
    for (int i = 0; i < nu; ++i)
      for (int j = 0; j < nv; ++j) {
        p.push_back(o + (i + 0.5) / nu * u + (j + 0.5) / nv * v);
        n.push_back(normal);
        face.push_back(f);
      }
  }
  fe::Samples samples() const {
    fe::Samples s;
    s.points.resize(static_cast<Eigen::Index>(p.size()), 3);
    s.normals.resize(s.points.rows(), 3);
    s.face_ids.resize(s.points.rows());
    for (std::size_t i = 0; i < p.size(); ++i) {
      s.points.row(static_cast<Eigen::Index>(i)) = p[i].transpose();
      s.normals.row(static_cast<Eigen::Index>(i)) = n[i].transpose();
      s.face_ids(static_cast<Eigen::Index>(i)) = face[i];
    }
    return s;
  }
  int nearest(const Eigen::Vector3d& q, double* d) const {
    int best = -1;
    double bd = INFINITY;
    for (std::size_t i = 0; i < p.size(); ++i)
      if ((p[i] - q).norm() < bd) { bd = (p[i] - q).norm(); best = static_cast<int>(i); }
    *d = bd;
    return best;
  }
  fe::Clearance::Nearest nearest_point() const {
    return [this](const Eigen::Vector3d& q) -> Eigen::Vector3d {
      double d;
      const int i = nearest(q, &d);
      return i < 0 ? Eigen::Vector3d::Constant(INFINITY) : p[static_cast<std::size_t>(i)];
    };
  }
  fe::Clearance::Distance distance() const {
    return [this](const Eigen::Vector3d& q) {
      double d;
      nearest(q, &d);
      return d;
    };
  }
};

constexpr double kH = 0.1;

// A step 4 long (y): its floor (z = 0, x 0..2) and its wall (x = 0, z 0..2, facing +x).
Cloud step() {
  Cloud c;
  c.rect({0, 0, 0}, {2, 0, 0}, {0, 4, 0}, {0, 0, 1}, 1, kH);
  c.rect({0, 0, 0}, {0, 4, 0}, {0, 0, 2}, {1, 0, 0}, 2, kH);
  return c;
}

}  // namespace

TEST(Clearance, ASlotsOtherWallObstructsTheStepsOpenSide) {
  const Cloud ref = step();
  const fe::Samples rs = ref.samples();
  std::vector<Eigen::Index> rows(rs.size());
  for (std::size_t i = 0; i < rows.size(); ++i) rows[i] = static_cast<Eigen::Index>(i);
  const fe::Clearance c(rs.points, rs.normals, rows, ref.nearest_point(), {0, 0, 0}, {2, 4, 2}, kH, 0.3);
  ASSERT_GT(c.rays(), 100u);
  const Eigen::Matrix4d I = Eigen::Matrix4d::Identity();
  // on a step like itself nothing is in the way
  EXPECT_LT(c.obstructed(I, ref.distance(), 1.5 * kH, 0), 0.02);
  // on a slot (the same, plus a wall facing back at x = 2.1) the wall's rays meet that wall
  Cloud slot = step();
  slot.rect({2.1, 0, 0}, {0, 4, 0}, {0, 0, 2}, {-1, 0, 0}, 3, kH);
  const double blocked = c.obstructed(I, slot.distance(), 1.5 * kH, 0);
  EXPECT_GT(blocked, 0.3);  // the wall's half of the rays
  EXPECT_LT(blocked, 0.7);  // the floor's rays go up, free
  // a wall farther away than the margin past the reference's box is not the feature's business
  Cloud wide = step();
  wide.rect({3, 0, 0}, {0, 4, 0}, {0, 0, 2}, {-1, 0, 0}, 3, kH);
  EXPECT_LT(c.obstructed(I, wide.distance(), 1.5 * kH, 0), 0.02);
}

// A channel 4 long (y): its floor (z = 0, x 0..w) between two walls 1 high facing each other.
Cloud channel(double w) {
  Cloud c;
  c.rect({0, 0, 0}, {w, 0, 0}, {0, 4, 0}, {0, 0, 1}, 1, kH);
  c.rect({0, 0, 0}, {0, 4, 0}, {0, 0, 1}, {1, 0, 0}, 2, kH);
  c.rect({w, 0, 0}, {0, 4, 0}, {0, 0, 1}, {-1, 0, 0}, 3, kH);
  return c;
}

std::vector<Eigen::Index> all_rows(const fe::Samples& s) {
  std::vector<Eigen::Index> rows(s.size());
  for (std::size_t i = 0; i < rows.size(); ++i) rows[i] = static_cast<Eigen::Index>(i);
  return rows;
}

TEST(Clearance, AChannelSqueezedAcrossIsNotObstructedByItsOwnWalls) {
  // issue 9: a machined pocket matched at 0.4x across (a topology match). The floor's rays run up
  // beside the walls; squeezed, the samples next to a wall would see it within the hit distance.
  const Cloud ref = channel(2);
  const fe::Samples rs = ref.samples();
  const fe::Clearance c(rs.points, rs.normals, all_rows(rs), ref.nearest_point(), {0, 0, 0}, {2, 4, 1}, kH, 0.3);
  const Cloud narrow = channel(0.8);
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
  H(0, 0) = 0.4;
  EXPECT_LT(c.obstructed(H, narrow.distance(), 1.5 * kH, 0), 0.05);
  // the same map onto a channel whose floor is crossed by a rib halfway up is obstructed
  Cloud ribbed = channel(0.8);
  ribbed.rect({0, 0, 0.5}, {0.8, 0, 0}, {0, 4, 0}, {0, 0, -1}, 4, kH);
  EXPECT_GT(c.obstructed(H, ribbed.distance(), 1.5 * kH, 0), 0.3);
}

TEST(Clearance, RaysLeavingTheBoxReachAsFarAsTheMapsScale) {
  // A step squeezed 0.4x along its open side (x) onto two walls of a passage whose far wall stands
  // at x = 1.5: the wall's rays left the reference's box at x = 2.3, 0.92 once squeezed; at the
  // map's scale (0.74) they reach the far wall, which a step has no business meeting.
  const Cloud ref = step();
  const fe::Samples rs = ref.samples();
  const fe::Clearance c(rs.points, rs.normals, all_rows(rs), ref.nearest_point(), {0, 0, 0}, {2, 4, 2}, kH, 0.3);
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
  H(0, 0) = 0.4;
  Cloud squeezed;
  squeezed.rect({0, 0, 0}, {0.8, 0, 0}, {0, 4, 0}, {0, 0, 1}, 1, kH);
  squeezed.rect({0, 0, 0}, {0, 4, 0}, {0, 0, 2}, {1, 0, 0}, 2, kH);
  EXPECT_LT(c.obstructed(H, squeezed.distance(), 1.5 * kH, 0), 0.02);
  Cloud passage = squeezed;
  passage.rect({1.5, 0, 0}, {0, 4, 0}, {0, 0, 2}, {-1, 0, 0}, 3, kH);
  EXPECT_GT(c.obstructed(H, passage.distance(), 1.5 * kH, 0), 0.3);
}

TEST(WholeFaces, AFaceOnPartOfALargerFaceIsPartialUntilTheFitCoversIt) {
  const Cloud ref = step();
  const fe::Samples rs = ref.samples();
  // the target: a step whose floor is twice as wide (x 0..4)
  Cloud tgt;
  tgt.rect({0, 0, 0}, {4, 0, 0}, {0, 4, 0}, {0, 0, 1}, 1, kH);
  tgt.rect({0, 0, 0}, {0, 4, 0}, {0, 0, 2}, {1, 0, 0}, 2, kH);
  const fe::Samples ts = tgt.samples();
  fe::FaceCoverCheck check;
  check.reference = &rs;
  for (std::size_t i = 0; i < rs.size(); ++i) check.rows.push_back(static_cast<Eigen::Index>(i));
  check.checked = {0, 1, 1};
  check.reference_spacing = kH;
  check.target_faces = &ts.face_ids;
  check.target_area = {0, 0, 0};
  for (std::size_t j = 0; j < ts.size(); ++j) check.target_area[static_cast<std::size_t>(ts.face_ids(static_cast<Eigen::Index>(j)))] += kH * kH;
  check.target_nearest = [&](const Eigen::Vector3d& q, double* d) { return tgt.nearest(q, d); };
  // laid as it is, the floor covers half of the target's floor: the floor's samples are partial
  const double floor_share = 2.0 * 4 / (2.0 * 4 + 4.0 * 2);
  EXPECT_NEAR(check.partial_share(Eigen::Matrix4d::Identity(), 2 * kH, 0.6), floor_share, 0.02);
  // stretched 2x along x (a fit grown over the whole floor), every face is covered (areas mapped by
  // Nanson's formula: the wall, normal to x, keeps its area)
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
  H(0, 0) = 2;
  EXPECT_LT(check.partial_share(H, 2 * kH, 0.6), 0.02);
  // on a target just like the reference nothing is partial
  check.target_area = {0, 2.0 * 4, 4.0 * 2};
  check.target_nearest = [&](const Eigen::Vector3d& q, double* d) { return ref.nearest(q, d); };
  const fe::Samples same = ref.samples();
  check.target_faces = &same.face_ids;
  EXPECT_LT(check.partial_share(Eigen::Matrix4d::Identity(), 2 * kH, 0.6), 0.02);
}
