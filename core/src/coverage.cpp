// The covered target region (coverage.h).
#include "coverage.h"

#include <Eigen/Geometry>  // .cross()

#include <algorithm>

namespace fe {

bool cover_target(const Points& mapped, const KdTree3& mapped_tree, double reach, double merge_reach, const ShapeDescription::Impl& T,
                  const TriangleMesh& tmesh, double face_coverage, Instance& inst) {
  Match& mt = inst.match;
  const Eigen::Vector3d lo = mapped.colwise().minCoeff().transpose() - Eigen::Vector3d::Constant(reach);
  const Eigen::Vector3d hi = mapped.colwise().maxCoeff().transpose() + Eigen::Vector3d::Constant(reach);
  std::vector<int> near;  // within reach: the instance's center, box and faces
  // dense samples per target face, and those within reach (Instance::touched: share by area)
  const bool sampled_faces = T.dense.face_ids.size() == T.dense.points.rows() && tmesh.num_faces > 0;
  std::vector<int> face_samples(sampled_faces ? static_cast<std::size_t>(tmesh.num_faces + 1) : 0, 0), face_near(face_samples.size(), 0);
  auto face_of = [&](Eigen::Index j) {
    const int f = T.dense.face_ids(j);
    return static_cast<std::size_t>(f > 0 && f <= tmesh.num_faces ? f : 0);
  };
  for (Eigen::Index j = 0; j < T.dense.points.rows(); ++j) {
    if (sampled_faces) ++face_samples[face_of(j)];
    const Eigen::Vector3d q = T.dense.points.row(j);
    if ((q.array() < lo.array()).any() || (q.array() > hi.array()).any()) continue;
    double d2;
    mapped_tree.nearest(q, &d2);
    const double d = std::sqrt(d2);
    if (d <= reach) near.push_back(static_cast<int>(j));
    // (what tells instances apart is where the fit lies, not the tolerance around it: a bead's fit
    // reaches its neighbour's flank 4 mm away at Motor-c's tolerance)
    if (d <= merge_reach) {
      inst.covered.push_back(static_cast<int>(j));
      if (sampled_faces) ++face_near[face_of(j)];
    }
  }
  for (std::size_t f = 1; f < face_samples.size(); ++f)
    if (face_samples[f] >= 20 && face_near[f] >= kTouchedShare * face_samples[f]) inst.touched.push_back(static_cast<int>(f));
  if (near.empty()) return false;
  Eigen::Vector3d c = Eigen::Vector3d::Zero(), bmin = Eigen::Vector3d::Constant(INFINITY), bmax = -bmin;
  for (int j : near) {
    const Eigen::Vector3d q = T.dense.points.row(j);
    c += q;
    bmin = bmin.cwiseMin(q);
    bmax = bmax.cwiseMax(q);
  }
  mt.center = c / static_cast<double>(near.size());
  mt.bbox_min = bmin;
  mt.bbox_max = bmax;
  // Faces and triangles: covered area per face (triangle centroids near the mapped reference).
  std::vector<double> face_area(static_cast<std::size_t>(tmesh.num_faces + 1), 0.0), face_cov(face_area.size(), 0.0);
  for (Eigen::Index t = 0; t < tmesh.triangles.rows(); ++t) {
    const Eigen::Vector3d a = tmesh.vertices.row(tmesh.triangles(t, 0)), b = tmesh.vertices.row(tmesh.triangles(t, 1)),
                          e = tmesh.vertices.row(tmesh.triangles(t, 2));
    const double area = 0.5 * (b - a).cross(e - a).norm();
    const int f = tmesh.face_ids.size() ? tmesh.face_ids(t) : 0;
    if (f > 0 && f <= tmesh.num_faces) face_area[static_cast<std::size_t>(f)] += area;
    const Eigen::Vector3d g = (a + b + e) / 3.0;
    if ((g.array() < lo.array()).any() || (g.array() > hi.array()).any()) continue;
    double d2;
    mapped_tree.nearest(g, &d2);
    if (std::sqrt(d2) > reach) continue;
    if (f > 0 && f <= tmesh.num_faces) face_cov[static_cast<std::size_t>(f)] += area;
    if (!tmesh.from_brep()) mt.triangles.push_back(static_cast<int>(t));
  }
  for (int f = 1; f <= tmesh.num_faces; ++f) {
    const double area = face_area[static_cast<std::size_t>(f)], covered = face_cov[static_cast<std::size_t>(f)];
    if (!(area > 0)) continue;
    if (covered >= face_coverage * area) mt.faces.push_back(f);
    if (covered >= kFaceShareFloor * area) mt.face_shares.emplace_back(f, std::min(1.0, covered / area));
  }
  return true;
}

}  // namespace fe
