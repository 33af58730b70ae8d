#include "skirt.h"

#include "regions.h"

#include <Eigen/Geometry>
#include <cstdint>
#include <map>
#include <vector>

namespace fe {

TriangleMesh border_skirt(const TriangleMesh& m, double width) {
  TriangleMesh s;
  s.source = m.source;
  s.vertices.resize(0, 3);
  s.triangles.resize(0, 3);
  s.face_ids.resize(0);
  if (m.triangles.rows() == 0 || !(width > 0)) return s;
  const std::vector<int> vid = weld_vertices(m.vertices, 1e-7 * m.diagonal());
  struct Use {
    int n = 0, a = 0, b = 0;  // uses; the vertices (rows of m.vertices) in the first use's order
    Eigen::Index t = 0;
  };
  std::map<std::uint64_t, Use> uses;  // welded edge -> its uses (a map: a fixed order)
  for (Eigen::Index t = 0; t < m.triangles.rows(); ++t)
    for (int k = 0; k < 3; ++k) {
      const int a = m.triangles(t, k), b = m.triangles(t, (k + 1) % 3);
      const auto u = static_cast<std::uint64_t>(vid[static_cast<std::size_t>(a)]), w = static_cast<std::uint64_t>(vid[static_cast<std::size_t>(b)]);
      if (u == w) continue;
      Use& e = uses[std::min(u, w) << 32 | std::max(u, w)];
      if (e.n++ == 0) {
        e.a = a;
        e.b = b;
        e.t = t;
      }
    }
  struct Edge {
    int a, b;  // welded ids, in the triangle's order
    Eigen::Vector3d pa, pb, out;
  };
  std::vector<Edge> edges;
  std::map<int, Eigen::Vector3d> dir;  // welded border vertex -> sum of its edges' outward directions
  for (const auto& [key, e] : uses) {
    if (e.n != 1) continue;
    const Eigen::Vector3d pa = m.vertices.row(e.a), pb = m.vertices.row(e.b);
    const Eigen::Vector3d p0 = m.vertices.row(m.triangles(e.t, 0)), p1 = m.vertices.row(m.triangles(e.t, 1)),
                          p2 = m.vertices.row(m.triangles(e.t, 2));
    const Eigen::Vector3d n = (p1 - p0).cross(p2 - p0);
    Eigen::Vector3d out = (pb - pa).cross(n);  // counter-clockwise about n: the triangle is on the left of a -> b
    if (!(out.norm() > 0)) continue;
    out.normalize();
    const int a = vid[static_cast<std::size_t>(e.a)], b = vid[static_cast<std::size_t>(e.b)];
    edges.push_back({a, b, pa, pb, out});
    for (const int v : {a, b}) {
      auto it = dir.emplace(v, Eigen::Vector3d::Zero()).first;
      it->second += out;
    }
  }
  if (edges.empty()) return s;
  s.vertices.resize(static_cast<Eigen::Index>(4 * edges.size()), 3);
  s.triangles.resize(static_cast<Eigen::Index>(2 * edges.size()), 3);
  s.face_ids = Eigen::VectorXi::Zero(static_cast<Eigen::Index>(2 * edges.size()));
  Eigen::Index v = 0, t = 0;
  for (const Edge& e : edges) {
    auto leave = [&](int w) {
      Eigen::Vector3d d = dir.at(w);
      // a vertex whose edges leave in opposite directions (a sliver) leaves along this edge's own
      if (d.norm() < 0.2) return e.out;
      d.normalize();
      // as far out from the edge as the edge's own direction would go (a corner's mean is shorter)
      const double c = d.dot(e.out);
      return c > 0.3 ? Eigen::Vector3d(d / c) : e.out;
    };
    const Eigen::Vector3d qa = e.pa + width * leave(e.a), qb = e.pb + width * leave(e.b);
    s.vertices.row(v) = e.pa.transpose();
    s.vertices.row(v + 1) = e.pb.transpose();
    s.vertices.row(v + 2) = qb.transpose();
    s.vertices.row(v + 3) = qa.transpose();
    // across the edge from its triangle, b -> a, so that the quad faces the way the triangle does
    s.triangles.row(t++) << static_cast<int>(v + 1), static_cast<int>(v), static_cast<int>(v + 3);
    s.triangles.row(t++) << static_cast<int>(v + 1), static_cast<int>(v + 3), static_cast<int>(v + 2);
    v += 4;
  }
  return s;
}

}  // namespace fe
