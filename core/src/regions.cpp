// Regions bounded by sharp edges, their contacts and corners (regions.h).
#include "regions.h"

#include "kdtree.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <unordered_map>

namespace fe {

std::vector<int> weld_vertices(const Points& v, double tolerance, Points* welded) {
  const auto n = static_cast<std::size_t>(v.rows());
  std::vector<int> id(n, -1);
  std::vector<Eigen::Index> first;
  if (n > 0) {
    const KdTree3 tree(v);
    std::vector<int> idx;
    std::vector<float> d2;
    for (std::size_t i = 0; i < n; ++i) {
      if (id[i] >= 0) continue;
      const int mine = static_cast<int>(first.size());
      first.push_back(static_cast<Eigen::Index>(i));
      id[i] = mine;
      tree.radius(v.row(static_cast<Eigen::Index>(i)).transpose(), tolerance, idx, d2);
      for (int j : idx)
        if (id[static_cast<std::size_t>(j)] < 0) id[static_cast<std::size_t>(j)] = mine;
    }
  }
  if (welded) {
    welded->resize(static_cast<Eigen::Index>(first.size()), 3);
    for (std::size_t k = 0; k < first.size(); ++k) welded->row(static_cast<Eigen::Index>(k)) = v.row(first[k]);
  }
  return id;
}

const RegionGraph::Contact* RegionGraph::contact(int a, int b) const {
  const auto& c = contacts[static_cast<std::size_t>(a)];
  const auto it = std::lower_bound(c.begin(), c.end(), b, [](const Contact& x, int o) { return x.other < o; });
  return it != c.end() && it->other == b ? &*it : nullptr;
}

namespace {

int root(std::vector<int>& parent, int i) {
  while (parent[static_cast<std::size_t>(i)] != i) {
    parent[static_cast<std::size_t>(i)] = parent[static_cast<std::size_t>(parent[static_cast<std::size_t>(i)])];
    i = parent[static_cast<std::size_t>(i)];
  }
  return i;
}

std::uint64_t edge_key(int a, int b) {
  const auto u = static_cast<std::uint64_t>(std::min(a, b)), w = static_cast<std::uint64_t>(std::max(a, b));
  return u << 32 | w;
}

// A region's border turns at a vertex when its two border edges there are not nearly in line.
constexpr double kStraightCos = -0.94;  // cos(160 degrees)
// A region is planar when every triangle normal lies within this of the mean.
constexpr double kPlanarCos = 0.9962;  // cos(5 degrees)

}  // namespace

RegionGraph region_graph(const TriangleMesh& m, double crease_degrees) {
  RegionGraph g;
  const Eigen::Index T = m.triangles.rows();
  if (T == 0) return g;
  const double diag = m.diagonal();
  Points wv;
  const std::vector<int> vid = weld_vertices(m.vertices, 1e-6 * diag, &wv);
  auto W = [&](Eigen::Index t, int k) { return vid[static_cast<std::size_t>(m.triangles(t, k))]; };

  // Triangle normals and areas; degenerate ones (after welding) take no part.
  Points tn(T, 3);
  std::vector<double> area(static_cast<std::size_t>(T), 0.0);
  std::vector<char> ok(static_cast<std::size_t>(T), 0);
  for (Eigen::Index t = 0; t < T; ++t) {
    const int a = W(t, 0), b = W(t, 1), c = W(t, 2);
    const Eigen::Vector3d n = (wv.row(b) - wv.row(a)).cross(wv.row(c) - wv.row(a)).transpose();
    const double len = n.norm();
    tn.row(t).setZero();
    if (a == b || b == c || a == c || !(len > 0)) continue;
    tn.row(t) = n.transpose() / len;
    area[static_cast<std::size_t>(t)] = 0.5 * len;
    ok[static_cast<std::size_t>(t)] = 1;
  }

  // Edges -> the triangles using them, in key order (so that nothing depends on a hash table's):
  // (edge, triangle) rows sorted, then one entry per edge.
  std::vector<std::pair<std::uint64_t, int>> uses;
  uses.reserve(static_cast<std::size_t>(3 * T));
  for (Eigen::Index t = 0; t < T; ++t) {
    if (!ok[static_cast<std::size_t>(t)]) continue;
    for (int k = 0; k < 3; ++k) uses.emplace_back(edge_key(W(t, k), W(t, (k + 1) % 3)), static_cast<int>(t));
  }
  std::sort(uses.begin(), uses.end());
  std::vector<std::pair<std::uint64_t, std::vector<int>>> sorted_edges;
  for (std::size_t i = 0; i < uses.size(); ++i) {
    if (i == 0 || uses[i].first != uses[i - 1].first) sorted_edges.emplace_back(uses[i].first, std::vector<int>{});
    sorted_edges.back().second.push_back(uses[i].second);
  }
  uses = {};
  // The third vertex of triangle t, off edge (a, b).
  auto apex = [&](int t, int a, int b) {
    for (int k = 0; k < 3; ++k) {
      const int v = W(t, k);
      if (v != a && v != b) return v;
    }
    return W(t, 0);
  };
  // Signed dihedral angle across edge (a, b) from triangle s to triangle t: > 0 convex.
  auto dihedral = [&](int s, int t, int a, int b) {
    const Eigen::Vector3d ns = tn.row(s), nt = tn.row(t);
    const double ang = std::acos(std::clamp(ns.dot(nt), -1.0, 1.0));
    const Eigen::Vector3d off = wv.row(apex(t, a, b)) - wv.row(a);
    return ns.dot(off) <= 0 ? ang : -ang;
  };

  // Regions: union across smooth edges, and within a B-rep face.
  std::vector<int> parent(static_cast<std::size_t>(T));
  std::iota(parent.begin(), parent.end(), 0);
  const double crease_cos = std::cos(crease_degrees * M_PI / 180.0);
  for (const auto& e : sorted_edges) {
    if (e.second.size() != 2) continue;
    const int s = e.second[0], t = e.second[1];
    const bool same_face = m.from_brep() && m.face_ids(s) == m.face_ids(t) && m.face_ids(s) > 0;
    if (same_face || tn.row(s).dot(tn.row(t)) >= crease_cos) parent[static_cast<std::size_t>(root(parent, s))] = root(parent, t);
  }
  g.triangle_region.assign(static_cast<std::size_t>(T), -1);
  std::unordered_map<int, int> region_of_root;
  for (Eigen::Index t = 0; t < T; ++t) {
    if (!ok[static_cast<std::size_t>(t)]) continue;
    const int r = root(parent, static_cast<int>(t));
    const auto it = region_of_root.emplace(r, static_cast<int>(region_of_root.size())).first;
    g.triangle_region[static_cast<std::size_t>(t)] = it->second;
  }
  const std::size_t R = region_of_root.size();
  g.regions.resize(R);
  g.contacts.resize(R);
  for (Eigen::Index t = 0; t < T; ++t) {
    const int r = g.triangle_region[static_cast<std::size_t>(t)];
    if (r < 0) continue;
    auto& reg = g.regions[static_cast<std::size_t>(r)];
    const double a = area[static_cast<std::size_t>(t)];
    reg.area += a;
    reg.centroid += a * (wv.row(W(t, 0)) + wv.row(W(t, 1)) + wv.row(W(t, 2))).transpose() / 3.0;
    reg.normal += a * tn.row(t).transpose();
  }
  for (auto& reg : g.regions) {
    if (reg.area > 0) reg.centroid /= reg.area;
    if (reg.normal.norm() > 0) reg.normal.normalize();
    reg.planar = true;
  }
  for (Eigen::Index t = 0; t < T; ++t) {
    const int r = g.triangle_region[static_cast<std::size_t>(t)];
    if (r >= 0 && tn.row(t).dot(g.regions[static_cast<std::size_t>(r)].normal) < kPlanarCos) g.regions[static_cast<std::size_t>(r)].planar = false;
  }

  // Border edges: between regions (contacts) or open. Per region, the border edges at each vertex.
  struct Acc {
    double length = 0, weighted = 0;
  };
  std::vector<std::unordered_map<int, Acc>> acc(R);
  std::unordered_map<int, int> vrow;  // welded vertex -> row of g.vertices
  auto vertex = [&](int v) -> RegionGraph::Vertex& {
    const auto it = vrow.emplace(v, static_cast<int>(g.vertices.size()));
    if (it.second) {
      g.vertices.emplace_back();
      g.vertices.back().point = wv.row(v).transpose();
    }
    return g.vertices[static_cast<std::size_t>(it.first->second)];
  };
  // (region, vertex) -> the other ends of that region's border edges at the vertex
  std::unordered_map<std::uint64_t, std::vector<int>> ends;
  auto border_edge = [&](int r, int a, int b) {
    ends[static_cast<std::uint64_t>(r) << 32 | static_cast<std::uint32_t>(a)].push_back(b);
    ends[static_cast<std::uint64_t>(r) << 32 | static_cast<std::uint32_t>(b)].push_back(a);
  };
  for (const auto& e : sorted_edges) {
    const int a = static_cast<int>(e.first >> 32), b = static_cast<int>(e.first & 0xffffffffu);
    const auto& ts = e.second;
    const double len = (wv.row(a) - wv.row(b)).norm();
    if (ts.size() == 1) {
      const int r = g.triangle_region[static_cast<std::size_t>(ts[0])];
      g.regions[static_cast<std::size_t>(r)].open = true;
      vertex(a).open = true;
      vertex(b).open = true;
      g.open_edges.push_back({vrow[a], vrow[b]});
      g.open_edge_region.push_back(r);
      border_edge(r, a, b);
      continue;
    }
    bool border = false;
    for (std::size_t i = 0; i < ts.size(); ++i)
      for (std::size_t j = 0; j < ts.size(); ++j) {
        const int ri = g.triangle_region[static_cast<std::size_t>(ts[i])], rj = g.triangle_region[static_cast<std::size_t>(ts[j])];
        if (i == j || ri == rj) continue;
        border = true;
        if (ts.size() == 2) {  // a manifold edge: its dihedral angle (non-manifold ones only join)
          auto& c = acc[static_cast<std::size_t>(ri)][rj];
          c.length += len;
          c.weighted += len * dihedral(ts[i], ts[j], a, b);
        } else {
          acc[static_cast<std::size_t>(ri)][rj].length += len;
        }
      }
    if (!border) continue;
    std::vector<int> seen;
    for (int t : ts) {
      const int r = g.triangle_region[static_cast<std::size_t>(t)];
      if (std::find(seen.begin(), seen.end(), r) != seen.end()) continue;
      seen.push_back(r);
      border_edge(r, a, b);
      vertex(a);
      vertex(b);
    }
  }
  for (std::size_t r = 0; r < R; ++r) {
    for (const auto& c : acc[r]) g.contacts[r].push_back({c.first, c.second.length > 0 ? c.second.weighted / c.second.length : 0, c.second.length});
    std::sort(g.contacts[r].begin(), g.contacts[r].end(), [](const auto& x, const auto& y) { return x.other < y.other; });
  }
  // Regions around each border vertex (from every triangle using it).
  for (Eigen::Index t = 0; t < T; ++t) {
    const int r = g.triangle_region[static_cast<std::size_t>(t)];
    if (r < 0) continue;
    for (int k = 0; k < 3; ++k) {
      const auto it = vrow.find(W(t, k));
      if (it == vrow.end()) continue;
      auto& rs = g.vertices[static_cast<std::size_t>(it->second)].regions;
      if (std::find(rs.begin(), rs.end(), r) == rs.end()) rs.push_back(r);
    }
  }
  // Corners of each region: where its border turns (or branches).
  for (const auto& e : ends) {  // (each entry's outcome is independent of the order)
    const int r = static_cast<int>(e.first >> 32), v = static_cast<int>(e.first & 0xffffffffu);
    auto& vx = g.vertices[static_cast<std::size_t>(vrow[v])];
    g.regions[static_cast<std::size_t>(r)].border.push_back(vrow[v]);
    bool turns = e.second.size() != 2;
    if (!turns) {
      const Eigen::Vector3d d1 = (wv.row(e.second[0]) - wv.row(v)).transpose().normalized();
      const Eigen::Vector3d d2 = (wv.row(e.second[1]) - wv.row(v)).transpose().normalized();
      turns = d1.dot(d2) > kStraightCos;
    }
    if (turns) vx.turning.push_back(r);
  }
  for (auto& vx : g.vertices) {
    std::sort(vx.regions.begin(), vx.regions.end());
    std::sort(vx.turning.begin(), vx.turning.end());
  }
  for (auto& reg : g.regions) std::sort(reg.border.begin(), reg.border.end());
  return g;
}

void mark_cut(RegionGraph& g, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const std::array<bool, 6>& cut_sides,
              double tolerance) {
  for (std::size_t e = 0; e < g.open_edges.size(); ++e) {
    const Eigen::Vector3d& a = g.vertices[static_cast<std::size_t>(g.open_edges[e][0])].point;
    const Eigen::Vector3d& b = g.vertices[static_cast<std::size_t>(g.open_edges[e][1])].point;
    bool on = false;
    for (int axis = 0; axis < 3 && !on; ++axis)
      for (int side = 0; side < 2 && !on; ++side) {
        if (!cut_sides[static_cast<std::size_t>(2 * axis + side)]) continue;
        const double w = side ? hi(axis) : lo(axis);
        on = std::abs(a(axis) - w) <= tolerance && std::abs(b(axis) - w) <= tolerance;
      }
    if (!on) continue;
    g.regions[static_cast<std::size_t>(g.open_edge_region[e])].cut = true;
    g.vertices[static_cast<std::size_t>(g.open_edges[e][0])].on_cut = true;
    g.vertices[static_cast<std::size_t>(g.open_edges[e][1])].on_cut = true;
  }
}

}  // namespace fe
