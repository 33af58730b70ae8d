// References as users make them: cut faces of a box-cut solid, mirror images (see reference.h).
#include "featureextract/reference.h"

#include "description.h"
#include "featureextract/geometry.h"
#include "kdtree.h"

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <algorithm>
#include <bitset>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <tuple>
#include <unordered_map>

namespace fe {

namespace {

// Vertices welded by position (a B-rep tessellation repeats edge nodes face by face; STL repeats all).
std::vector<int> weld(const Points& v, double quantum) {
  std::map<std::tuple<long long, long long, long long>, int> ids;
  std::vector<int> out(static_cast<std::size_t>(v.rows()));
  for (Eigen::Index i = 0; i < v.rows(); ++i) {
    const auto key = std::make_tuple(std::llround(v(i, 0) / quantum), std::llround(v(i, 1) / quantum), std::llround(v(i, 2) / quantum));
    out[static_cast<std::size_t>(i)] = ids.emplace(key, static_cast<int>(ids.size())).first->second;
  }
  return out;
}

int find_root(std::vector<int>& parent, int i) {
  while (parent[static_cast<std::size_t>(i)] != i) {
    parent[static_cast<std::size_t>(i)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(i)])];
    i = parent[static_cast<std::size_t>(i)];
  }
  return i;
}

// Share of an open region's border length that must lie along a bounding-box side for the side to
// count as cut; or, as a share of the side's shorter extent, the border that crosses it (one plane
// clipped across the whole side is a cut, however much border the region has elsewhere: FTC-10's
// drilled hole, whose box took a pocket corner and the part's face beyond it, ran 0.097 of its
// border along -z, the whole width of that side).
constexpr double kBorderShare = 0.1;
constexpr double kSideSpan = 0.5;

// The bounding-box plane (0..5 = -x, +x, -y, +y, -z, +z) a triangle lies in, facing out, or -1.
int box_plane(const TriangleMesh& m, Eigen::Index t, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, double tol) {
  const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)), b = m.vertices.row(m.triangles(t, 1)), c = m.vertices.row(m.triangles(t, 2));
  const Eigen::Vector3d n = (b - a).cross(c - a);
  if (!(n.norm() > 0)) return -1;
  const Eigen::Vector3d u = n.normalized();
  for (int axis = 0; axis < 3; ++axis)
    for (int side = 0; side < 2; ++side) {
      const double w = side ? hi(axis) : lo(axis);
      const double facing = side ? u(axis) : -u(axis);
      if (facing > 0.999 && std::abs(a(axis) - w) <= tol && std::abs(b(axis) - w) <= tol && std::abs(c(axis) - w) <= tol) return 2 * axis + side;
    }
  return -1;
}

// The count, the cut sides (from each cut triangle's bounding-box plane, `plane`) and the B-rep faces
// of the triangles marked in out.cut_triangle.
void summarize_cut(const TriangleMesh& m, const std::vector<int>& plane, CutFaces& out) {
  out.triangles = 0;
  out.cut_sides.fill(false);
  out.faces.clear();
  std::vector<char> is_cut(static_cast<std::size_t>(std::max(m.num_faces, 0) + 1), 0);
  for (std::size_t t = 0; t < out.cut_triangle.size(); ++t) {
    if (!out.cut_triangle[t]) continue;
    ++out.triangles;
    if (plane[t] >= 0) out.cut_sides[static_cast<std::size_t>(plane[t])] = true;
    if (m.from_brep()) is_cut[static_cast<std::size_t>(std::clamp(m.face_ids(static_cast<Eigen::Index>(t)), 0, m.num_faces))] = 1;
  }
  for (int f = 1; f <= m.num_faces; ++f)
    if (is_cut[static_cast<std::size_t>(f)]) out.faces.push_back(f);
}

// Connected triangles in one bounding-box plane (`plane`, from box_plane; -1 elsewhere): per triangle
// a region id, or -1 (mesh input, where no B-rep face says which triangles belong together).
std::vector<int> coplanar_regions(const TriangleMesh& m, const std::vector<int>& plane, const std::vector<int>& vid) {
  const Eigen::Index T = m.triangles.rows();
  std::vector<int> parent(static_cast<std::size_t>(T));
  std::iota(parent.begin(), parent.end(), 0);
  std::unordered_map<std::uint64_t, int> first;  // (welded vertex, plane) -> a triangle
  for (Eigen::Index t = 0; t < T; ++t) {
    const int p = plane[static_cast<std::size_t>(t)];
    if (p < 0) continue;
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t key = static_cast<std::uint64_t>(vid[static_cast<std::size_t>(m.triangles(t, k))]) * 8 + static_cast<std::uint64_t>(p);
      const auto it = first.emplace(key, static_cast<int>(t));
      if (!it.second) parent[static_cast<std::size_t>(find_root(parent, static_cast<int>(t)))] = find_root(parent, it.first->second);
    }
  }
  std::vector<int> region(static_cast<std::size_t>(T), -1);
  for (Eigen::Index t = 0; t < T; ++t)
    if (plane[static_cast<std::size_t>(t)] >= 0) region[static_cast<std::size_t>(t)] = find_root(parent, static_cast<int>(t));
  return region;
}

// A clipped region's own faces in two opposite planes of its box (CutFaces::own_triangle): per
// unclipped side, the coplanar regions lying in it that reach every clipped side around it (at least
// two); where both sides of one axis have such a region, their triangles are marked.
void mark_through_planes(const TriangleMesh& m, const std::vector<int>& vid, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                         double tol, CutFaces& out) {
  const Eigen::Index T = m.triangles.rows();
  std::vector<int> plane(static_cast<std::size_t>(T), -1);
  for (Eigen::Index t = 0; t < T; ++t) {
    const int p = box_plane(m, t, lo, hi, tol);
    if (p >= 0 && !out.cut_sides[static_cast<std::size_t>(p)]) plane[static_cast<std::size_t>(t)] = p;
  }
  const std::vector<int> region = coplanar_regions(m, plane, vid);
  std::unordered_map<int, unsigned> reached;  // region -> bounding-box sides its vertices lie on (bit per side)
  for (Eigen::Index t = 0; t < T; ++t) {
    const int r = region[static_cast<std::size_t>(t)];
    if (r < 0) continue;
    unsigned& bits = reached[r];
    for (int k = 0; k < 3; ++k)
      for (int axis = 0; axis < 3; ++axis) {
        const double x = m.vertices(m.triangles(t, k), axis);
        if (std::abs(x - lo(axis)) <= tol) bits |= 1u << (2 * axis);
        if (std::abs(x - hi(axis)) <= tol) bits |= 1u << (2 * axis + 1);
      }
  }
  std::unordered_map<int, char> spans;  // region -> it reaches every clipped side around its plane
  std::array<bool, 6> side_spanned{};
  for (Eigen::Index t = 0; t < T; ++t) {
    const int r = region[static_cast<std::size_t>(t)];
    if (r < 0 || spans.count(r)) continue;
    const int axis = plane[static_cast<std::size_t>(t)] / 2;
    unsigned around = 0;
    for (int s = 0; s < 6; ++s)
      if (s / 2 != axis && out.cut_sides[static_cast<std::size_t>(s)]) around |= 1u << s;
    const bool ok = std::bitset<6>(around).count() >= 2 && (reached[r] & around) == around;
    spans[r] = ok;
    if (ok) side_spanned[static_cast<std::size_t>(plane[static_cast<std::size_t>(t)])] = true;
  }
  out.own_triangle.assign(static_cast<std::size_t>(T), 0);
  out.own_triangles = 0;
  for (Eigen::Index t = 0; t < T; ++t) {
    const int r = region[static_cast<std::size_t>(t)];
    if (r < 0 || !spans[r]) continue;
    const int p = plane[static_cast<std::size_t>(t)];
    if (!side_spanned[static_cast<std::size_t>(p ^ 1)]) continue;  // the opposite side has none: not passed through
    out.own_triangle[static_cast<std::size_t>(t)] = 1;
    ++out.own_triangles;
  }
}

}  // namespace

CutFaces detect_cut_faces(const TriangleMesh& m, double tolerance) {
  CutFaces out;
  const Eigen::Index T = m.triangles.rows();
  out.cut_triangle.assign(static_cast<std::size_t>(T), 0);
  if (T == 0) return out;
  const Eigen::Vector3d lo = m.vertices.colwise().minCoeff().transpose(), hi = m.vertices.colwise().maxCoeff().transpose();
  const double diag = (hi - lo).norm();
  if (!(diag > 0)) return out;
  const double tol = tolerance * diag;
  const std::vector<int> vid = weld(m.vertices, 1e-7 * diag);

  // Closed surface? Count edges used by one triangle only (by length).
  std::unordered_map<std::uint64_t, std::pair<int, double>> edges;  // welded edge -> uses, length
  double total = 0;
  for (Eigen::Index t = 0; t < T; ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = m.triangles(t, k), b = m.triangles(t, (k + 1) % 3);
      const auto u = static_cast<std::uint64_t>(vid[static_cast<std::size_t>(a)]), w = static_cast<std::uint64_t>(vid[static_cast<std::size_t>(b)]);
      const double len = (m.vertices.row(a) - m.vertices.row(b)).norm();
      auto& e = edges[std::min(u, w) << 32 | std::max(u, w)];
      ++e.first;
      e.second = len;
      total += len;
    }
  double open = 0;
  for (const auto& e : edges)
    if (e.second.first == 1) open += e.second.second;
  // (a little open length from welding is tolerated; a region clipped out of a fine mesh has a
  // border of at least about its box's diagonal, however small a share of all its edges that is)
  out.closed = open <= 0.005 * total && open <= 0.1 * diag;
  if (!out.closed) {
    // An open mesh region (not picked B-rep faces) whose border runs along sides of its bounding box
    // was clipped out of a mesh with a box: those sides are cut, though no cut face closes them.
    if (m.from_brep() || !(open > 0)) return out;
    std::array<double, 6> along{};
    for (Eigen::Index t = 0; t < T; ++t) {
      const Eigen::Vector3d n = (m.vertices.row(m.triangles(t, 1)) - m.vertices.row(m.triangles(t, 0)))
                                    .cross(m.vertices.row(m.triangles(t, 2)) - m.vertices.row(m.triangles(t, 0)))
                                    .transpose()
                                    .normalized();
      for (int k = 0; k < 3; ++k) {
        const int a = m.triangles(t, k), b = m.triangles(t, (k + 1) % 3);
        const auto u = static_cast<std::uint64_t>(vid[static_cast<std::size_t>(a)]), w = static_cast<std::uint64_t>(vid[static_cast<std::size_t>(b)]);
        const auto& e = edges[std::min(u, w) << 32 | std::max(u, w)];
        if (e.first != 1) continue;
        for (int axis = 0; axis < 3; ++axis)
          for (int side = 0; side < 2; ++side) {
            // the surface must cross the side (a face lying in it, like a plate's bottom, is not cut there)
            if (!(std::abs(n(axis)) < 0.9)) continue;
            const double wv = side ? hi(axis) : lo(axis);
            if (std::abs(m.vertices(a, axis) - wv) <= tol && std::abs(m.vertices(b, axis) - wv) <= tol)
              along[static_cast<std::size_t>(2 * axis + side)] += e.second;
          }
      }
    }
    for (std::size_t s = 0; s < 6; ++s) {
      const int axis = static_cast<int>(s / 2);
      const double span = std::min(hi((axis + 1) % 3) - lo((axis + 1) % 3), hi((axis + 2) % 3) - lo((axis + 2) % 3));
      out.cut_sides[s] = along[s] >= kBorderShare * open || along[s] >= kSideSpan * span;
    }
    mark_through_planes(m, vid, lo, hi, tol, out);
    return out;
  }

  // Plane of the bounding box each triangle lies in (0..5 = -x, +x, -y, +y, -z, +z), facing out.
  std::vector<int> plane(static_cast<std::size_t>(T), -1);
  std::vector<double> area(static_cast<std::size_t>(T), 0.0);
  double total_area = 0;
  for (Eigen::Index t = 0; t < T; ++t) {
    const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)), b = m.vertices.row(m.triangles(t, 1)), c = m.vertices.row(m.triangles(t, 2));
    area[static_cast<std::size_t>(t)] = 0.5 * (b - a).cross(c - a).norm();
    total_area += area[static_cast<std::size_t>(t)];
    plane[static_cast<std::size_t>(t)] = box_plane(m, t, lo, hi, tol);
  }
  // Regions: B-rep faces (all of whose triangles lie in one plane), or connected coplanar triangles.
  std::vector<int> region(static_cast<std::size_t>(T));
  if (m.from_brep()) {
    std::vector<int> face_plane(static_cast<std::size_t>(m.num_faces + 1), -2);  // -2 unseen, -1 not in one plane
    for (Eigen::Index t = 0; t < T; ++t) {
      const int f = m.face_ids(t);
      int& fp = face_plane[static_cast<std::size_t>(std::clamp(f, 0, m.num_faces))];
      const int p = plane[static_cast<std::size_t>(t)];
      fp = fp == -2 ? p : (fp == p ? fp : -1);
    }
    for (Eigen::Index t = 0; t < T; ++t) {
      const int f = std::clamp(m.face_ids(t), 0, m.num_faces);
      region[static_cast<std::size_t>(t)] = face_plane[static_cast<std::size_t>(f)] >= 0 && f > 0 ? f : -1;
    }
  } else {
    region = coplanar_regions(m, plane, vid);
  }
  // A region is cut if it reaches a bounding-box plane of another axis.
  std::unordered_map<int, char> reaches;
  for (Eigen::Index t = 0; t < T; ++t) {
    const int r = region[static_cast<std::size_t>(t)];
    if (r < 0) continue;
    const int axis = plane[static_cast<std::size_t>(t)] / 2;
    char& hit = reaches[r];
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d x = m.vertices.row(m.triangles(t, k));
      for (int other = 0; other < 3; ++other)
        if (other != axis && (std::abs(x(other) - lo(other)) <= tol || std::abs(x(other) - hi(other)) <= tol)) hit = 1;
    }
  }
  double cut_area = 0;
  for (Eigen::Index t = 0; t < T; ++t) {
    const int r = region[static_cast<std::size_t>(t)];
    if (r >= 0 && reaches[r]) {
      out.cut_triangle[static_cast<std::size_t>(t)] = 1;
      cut_area += area[static_cast<std::size_t>(t)];
    }
  }
  // A reference that would be (almost) all cut is a box-like feature itself: keep it whole.
  if (cut_area > 0.9 * total_area) {
    std::fill(out.cut_triangle.begin(), out.cut_triangle.end(), 0);
    return out;
  }
  summarize_cut(m, plane, out);
  return out;
}

Points through_rims(const TriangleMesh& m, const CutFaces& cut, Points* outward) {
  const Eigen::Index T = m.triangles.rows();
  if (cut.own_triangles == 0 || cut.own_triangle.size() != static_cast<std::size_t>(T)) {
    *outward = Points(0, 3);
    return Points(0, 3);
  }
  const std::vector<int> vid = weld(m.vertices, 1e-7 * m.diagonal());
  std::vector<char> in_rest(static_cast<std::size_t>(m.vertices.rows()), 0);  // per welded vertex: used by a kept triangle
  for (Eigen::Index t = 0; t < T; ++t)
    if (!cut.own_triangle[static_cast<std::size_t>(t)])
      for (int k = 0; k < 3; ++k) in_rest[static_cast<std::size_t>(vid[static_cast<std::size_t>(m.triangles(t, k))])] = 1;
  std::map<int, std::pair<Eigen::Vector3d, Eigen::Vector3d>> rim;  // welded vertex -> (position, outward)
  for (Eigen::Index t = 0; t < T; ++t) {
    if (!cut.own_triangle[static_cast<std::size_t>(t)]) continue;
    const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)), b = m.vertices.row(m.triangles(t, 1)), c = m.vertices.row(m.triangles(t, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a).normalized();
    for (int k = 0; k < 3; ++k) {
      const int v = vid[static_cast<std::size_t>(m.triangles(t, k))];
      if (in_rest[static_cast<std::size_t>(v)]) rim.emplace(v, std::make_pair(Eigen::Vector3d(m.vertices.row(m.triangles(t, k)).transpose()), n));
    }
  }
  Points out(static_cast<Eigen::Index>(rim.size()), 3);
  *outward = Points(out.rows(), 3);
  Eigen::Index k = 0;
  for (const auto& [v, pn] : rim) {
    out.row(k) = pn.first.transpose();
    outward->row(k++) = pn.second.transpose();
  }
  return out;
}

Points open_border_points(const TriangleMesh& m, double step, std::vector<int>* face) {
  face->clear();
  if (!m.from_brep() || m.triangles.rows() == 0 || !(step > 0)) return Points(0, 3);
  const std::vector<int> vid = weld(m.vertices, 1e-7 * m.diagonal());
  struct Use {
    int n = 0, a = 0, b = 0, face = 0;
  };
  std::unordered_map<std::uint64_t, Use> uses;  // welded edge -> uses, its vertices and face
  for (Eigen::Index t = 0; t < m.triangles.rows(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = m.triangles(t, k), b = m.triangles(t, (k + 1) % 3);
      const auto u = static_cast<std::uint64_t>(vid[static_cast<std::size_t>(a)]), w = static_cast<std::uint64_t>(vid[static_cast<std::size_t>(b)]);
      Use& e = uses[std::min(u, w) << 32 | std::max(u, w)];
      e = {e.n + 1, a, b, m.face_ids(t)};
    }
  std::vector<std::tuple<int, double, double, double>> pts;  // (face, x, y, z)
  for (const auto& [key, e] : uses) {
    if (e.n != 1) continue;
    const Eigen::Vector3d a = m.vertices.row(e.a), b = m.vertices.row(e.b);
    const int n = std::max(1, static_cast<int>(std::ceil((b - a).norm() / step)));
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p = a + (b - a) * (static_cast<double>(i) / n);
      pts.emplace_back(e.face, p.x(), p.y(), p.z());
    }
  }
  std::sort(pts.begin(), pts.end());  // in a fixed order (the map's order is not)
  Points out(static_cast<Eigen::Index>(pts.size()), 3);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    out.row(static_cast<Eigen::Index>(i)) << std::get<1>(pts[i]), std::get<2>(pts[i]), std::get<3>(pts[i]);
    face->push_back(std::get<0>(pts[i]));
  }
  return out;
}

std::vector<char> faces_on_border(const TriangleMesh& m) {
  if (!m.from_brep() || m.triangles.rows() == 0) return {};
  std::vector<int> face;
  open_border_points(m, INFINITY, &face);  // one point per open edge is enough to know its face
  std::vector<char> out(static_cast<std::size_t>(m.num_faces + 1), 0);
  for (const int f : face) out[static_cast<std::size_t>(std::clamp(f, 0, m.num_faces))] = 1;
  out[0] = 0;
  return out;
}

namespace {

// Is x (outward normal n) on the surface sampled in `tree` (points P, normals N): a sample within
// `reach` whose normal agrees, among its 4 nearest (beside an edge the nearest may be the other face's)?
bool on_sampled_surface(const KdTree3& tree, const Samples& S, const Eigen::Vector3d& x, const Eigen::Vector3d& n, double reach) {
  thread_local std::vector<int> idx;
  thread_local std::vector<float> d2;
  tree.knn(x, 4, idx, d2);
  for (std::size_t k = 0; k < idx.size(); ++k)
    if (std::sqrt(static_cast<double>(d2[k])) <= reach && n.dot(S.normals.row(idx[k]).transpose()) > 0.9) return true;
  return false;
}

}  // namespace

std::vector<char> cut_faces_on_target(const TriangleMesh& reference, const CutFaces& cut, const TriangleMesh& target, double spacing) {
  const Eigen::Index T = reference.triangles.rows();
  std::vector<char> own(static_cast<std::size_t>(T), 0);
  if (cut.triangles == 0 || cut.cut_triangle.size() != static_cast<std::size_t>(T) || !(spacing > 0) || target.triangles.rows() == 0) return own;
  // the target's triangles near the reference's box, sampled like it
  const Eigen::Vector3d lo = reference.vertices.colwise().minCoeff().transpose().array() - 2 * spacing;
  const Eigen::Vector3d hi = reference.vertices.colwise().maxCoeff().transpose().array() + 2 * spacing;
  std::vector<char> far(static_cast<std::size_t>(target.triangles.rows()), 1);
  bool any = false;
  for (Eigen::Index t = 0; t < target.triangles.rows(); ++t) {
    Eigen::Vector3d tl = Eigen::Vector3d::Constant(INFINITY), th = Eigen::Vector3d::Constant(-INFINITY);
    for (int k = 0; k < 3; ++k) {
      tl = tl.cwiseMin(target.vertices.row(target.triangles(t, k)).transpose());
      th = th.cwiseMax(target.vertices.row(target.triangles(t, k)).transpose());
    }
    if ((th.array() >= lo.array()).all() && (tl.array() <= hi.array()).all()) far[static_cast<std::size_t>(t)] = 0, any = true;
  }
  if (!any) return own;
  const TriangleMesh near = without_triangles(target, far);
  // (a target far larger than the reference around it would take too many samples: not this case)
  if (!(mesh_area(near) / (spacing * spacing) < 4e6)) return own;
  const Samples ts = sample_surface(near, spacing, 11);
  if (ts.size() == 0) return own;
  const KdTree3 tree(ts.points);
  const double reach = 1.5 * spacing;
  // unmoved? the reference's other faces on the target
  const TriangleMesh rest = without_triangles(reference, cut.cut_triangle);
  if (rest.triangles.rows() == 0) return own;
  const Samples rs = sample_surface(rest, spacing, 12);
  std::size_t on = 0;
  for (Eigen::Index i = 0; i < rs.points.rows(); ++i) on += on_sampled_surface(tree, ts, rs.points.row(i).transpose(), rs.normals.row(i).transpose(), reach) ? 1 : 0;
  if (rs.size() == 0 || static_cast<double>(on) < 0.9 * static_cast<double>(rs.size())) return own;
  // each cut face (B-rep face, or triangle of mesh input) on the target?
  std::vector<char> uncut(static_cast<std::size_t>(T));
  std::vector<Eigen::Index> cut_rows;  // the cut mesh's triangle k is reference triangle cut_rows[k]
  for (Eigen::Index t = 0; t < T; ++t) {
    uncut[static_cast<std::size_t>(t)] = !cut.cut_triangle[static_cast<std::size_t>(t)];
    if (cut.cut_triangle[static_cast<std::size_t>(t)]) cut_rows.push_back(t);
  }
  const TriangleMesh cm = without_triangles(reference, uncut);
  const Samples cs = sample_surface(cm, spacing, 13);
  const bool by_face = reference.from_brep();
  std::map<long, std::pair<std::size_t, std::size_t>> tally;  // group -> (on, all)
  for (Eigen::Index i = 0; i < cs.points.rows(); ++i) {
    const Eigen::Index tri = cut_rows[static_cast<std::size_t>(cs.triangle_ids(i))];
    const long g = by_face ? static_cast<long>(reference.face_ids(tri)) : static_cast<long>(tri);
    auto& c = tally[g];
    c.first += on_sampled_surface(tree, ts, cs.points.row(i).transpose(), cs.normals.row(i).transpose(), reach) ? 1 : 0;
    ++c.second;
  }
  for (const Eigen::Index t : cut_rows) {
    const long g = by_face ? static_cast<long>(reference.face_ids(t)) : static_cast<long>(t);
    const auto it = tally.find(g);
    if (it != tally.end() && it->second.second >= 3 && static_cast<double>(it->second.first) >= 0.8 * static_cast<double>(it->second.second))
      own[static_cast<std::size_t>(t)] = 1;
  }
  return own;
}

CutFaces without_own_faces(const TriangleMesh& m, const CutFaces& cut, const std::vector<char>& own) {
  CutFaces out = cut;
  const Eigen::Index T = m.triangles.rows();
  if (own.size() != static_cast<std::size_t>(T) || cut.cut_triangle.size() != own.size()) return out;
  const Eigen::Vector3d lo = m.vertices.colwise().minCoeff().transpose(), hi = m.vertices.colwise().maxCoeff().transpose();
  const double tol = 2e-3 * (hi - lo).norm();  // detect_cut_faces' default tolerance
  std::vector<int> plane(static_cast<std::size_t>(T), -1);
  for (Eigen::Index t = 0; t < T; ++t) {
    if (own[static_cast<std::size_t>(t)]) out.cut_triangle[static_cast<std::size_t>(t)] = 0;
    if (out.cut_triangle[static_cast<std::size_t>(t)]) plane[static_cast<std::size_t>(t)] = box_plane(m, t, lo, hi, tol);
  }
  summarize_cut(m, plane, out);
  return out;
}

TriangleMesh without_triangles(const TriangleMesh& m, const std::vector<char>& drop) {
  TriangleMesh out;
  out.source = m.source;
  out.num_faces = m.num_faces;
  out.dropped_degenerate = m.dropped_degenerate;
  out.reoriented = m.reoriented;
  std::vector<int> new_id(static_cast<std::size_t>(m.vertices.rows()), -1);
  std::vector<Eigen::Index> kept;
  for (Eigen::Index t = 0; t < m.triangles.rows(); ++t)
    if (static_cast<std::size_t>(t) >= drop.size() || !drop[static_cast<std::size_t>(t)]) kept.push_back(t);
  int nv = 0;
  for (Eigen::Index t : kept)
    for (int k = 0; k < 3; ++k)
      if (new_id[static_cast<std::size_t>(m.triangles(t, k))] < 0) new_id[static_cast<std::size_t>(m.triangles(t, k))] = nv++;
  out.vertices.resize(nv, 3);
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v)
    if (new_id[static_cast<std::size_t>(v)] >= 0) out.vertices.row(new_id[static_cast<std::size_t>(v)]) = m.vertices.row(v);
  out.triangles.resize(static_cast<Eigen::Index>(kept.size()), 3);
  out.face_ids.resize(static_cast<Eigen::Index>(kept.size()));
  for (std::size_t i = 0; i < kept.size(); ++i) {
    for (int k = 0; k < 3; ++k) out.triangles(static_cast<Eigen::Index>(i), k) = new_id[static_cast<std::size_t>(m.triangles(kept[i], k))];
    out.face_ids(static_cast<Eigen::Index>(i)) = m.face_ids.size() ? m.face_ids(kept[i]) : 0;
  }
  return out;
}

TriangleMesh placed_mesh(const TriangleMesh& m, const Eigen::Matrix4d& H) {
  TriangleMesh out = m;
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) out.vertices.row(i) = apply_transform(H, m.vertices.row(i).transpose()).transpose();
  if (H.topLeftCorner<3, 3>().determinant() < 0) {
    out.triangles.col(1) = m.triangles.col(2);
    out.triangles.col(2) = m.triangles.col(1);
  }
  return out;
}

TriangleMesh mirrored_mesh(const TriangleMesh& m, const Eigen::Vector3d& center, Eigen::Matrix4d* M) {
  TriangleMesh out = m;
  out.vertices.col(0) = (2.0 * center.x()) - m.vertices.col(0).array();
  out.triangles.col(1) = m.triangles.col(2);
  out.triangles.col(2) = m.triangles.col(1);
  out.source = m.source.empty() ? "mirrored reference" : m.source + " (mirrored)";
  if (M) {
    M->setIdentity();
    (*M)(0, 0) = -1;
    (*M)(0, 3) = 2.0 * center.x();
  }
  return out;
}

bool is_mirror_symmetric(const Points& points, const Points& normals, double tolerance, double fraction) {
  const Eigen::Index n = points.rows();
  if (n < 10 || normals.rows() != n) return false;
  const KdTree3 tree(points);
  const Eigen::RowVector3d c = points.colwise().mean();
  const Points centered = points.rowwise() - c;
  const Eigen::Matrix3d cov = centered.transpose() * centered / static_cast<double>(n);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  std::vector<Eigen::Vector3d> planes = {es.eigenvectors().col(0), es.eigenvectors().col(1), es.eigenvectors().col(2),
                                         Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ()};
  const Eigen::Index step = std::max<Eigen::Index>(1, n / 600);
  for (const Eigen::Vector3d& u : planes) {
    int tried = 0, ok = 0;
    for (Eigen::Index i = 0; i < n; i += step) {
      ++tried;
      const Eigen::Vector3d p = points.row(i).transpose(), q = p - 2.0 * (p - c.transpose()).dot(u) * u;
      const Eigen::Vector3d nn = normals.row(i).transpose(), nq = nn - 2.0 * nn.dot(u) * u;
      double d2;
      const int j = tree.nearest(q, &d2);
      if (j >= 0 && std::sqrt(d2) <= tolerance && nq.dot(normals.row(j).transpose()) > 0.8) ++ok;
    }
    if (tried > 0 && ok >= fraction * tried) return true;
  }
  return false;
}

}  // namespace fe
