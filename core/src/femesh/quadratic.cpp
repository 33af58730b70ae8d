// Linear tetrahedra to quadratic ones (C3D10), see to_quadratic in featureextract/femesh.h.
#include "femesh_detail.h"

#include <limits>

namespace fe {

namespace {
constexpr int kEdge[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};  // Tet10's middle nodes 4..9

std::uint64_t edge_key(int a, int b) {
  if (a > b) std::swap(a, b);
  return static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32 | static_cast<std::uint32_t>(b);
}

// Smallest Jacobian ratio of a quadratic tetrahedron (femesh.h's Tet10 quality): <= 0 when folded.
bool folded(const FeMesh& m, const ElementBlock& b, Eigen::Index r) {
  FeMesh one;
  one.nodes.resize(10, 3);
  for (int j = 0; j < 10; ++j) one.nodes.row(j) = m.nodes.row(b.conn(r, j));
  ElementBlock e;
  e.type = ElementType::Tet10;
  e.conn.resize(1, 10);
  for (int j = 0; j < 10; ++j) e.conn(0, j) = j;
  one.blocks.push_back(e);
  return element_quality(one)[0].inverted;
}
}  // namespace

FeMesh to_quadratic(const FeMesh& m, const std::function<bool(int, int)>& on_surface,
                    const std::function<Eigen::Vector3d(int, int, const Eigen::Vector3d&)>& place, std::size_t* moved) {
  femesh_detail::check_mesh(m);
  FeMesh out = m;
  const Eigen::Index n0 = m.nodes.rows();
  std::unordered_map<std::uint64_t, int> middle;  // edge -> new node index
  std::vector<std::pair<int, int>> ends;           // per new node, its edge
  // a Tet10 block given keeps its middles, and a Tet4 neighbour shares them (no duplicate node on a shared edge)
  for (const ElementBlock& b : m.blocks) {
    if (b.type != ElementType::Tet10) continue;
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r)
      for (int e = 0; e < 6; ++e) middle.emplace(edge_key(b.conn(r, kEdge[e][0]), b.conn(r, kEdge[e][1])), b.conn(r, 4 + e));
  }
  for (const ElementBlock& b : m.blocks) {
    if (b.type != ElementType::Tet4) continue;
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r)
      for (const auto& e : kEdge) {
        const int a = b.conn(r, e[0]), c = b.conn(r, e[1]);
        if (middle.emplace(edge_key(a, c), static_cast<int>(n0 + static_cast<Eigen::Index>(ends.size()))).second) ends.push_back({a, c});
      }
  }
  const Eigen::Index added = static_cast<Eigen::Index>(ends.size());
  out.nodes.conservativeResize(n0 + added, 3);
  std::vector<char> surface(static_cast<std::size_t>(added), 0);
  for (Eigen::Index k = 0; k < added; ++k) {
    const auto [a, c] = ends[static_cast<std::size_t>(k)];
    out.nodes.row(n0 + k) = 0.5 * (m.nodes.row(a) + m.nodes.row(c));
    surface[static_cast<std::size_t>(k)] = !on_surface || on_surface(a, c);
  }
  if (!m.node_ids.empty()) {
    long next = *std::max_element(m.node_ids.begin(), m.node_ids.end());
    for (Eigen::Index k = 0; k < added; ++k) out.node_ids.push_back(++next);
  }
  std::vector<char> converted(out.blocks.size(), 0);  // the blocks made Tet10 here (a Tet10 block given has no new middles)
  for (std::size_t bi = 0; bi < out.blocks.size(); ++bi) {
    ElementBlock& b = out.blocks[bi];
    if (b.type != ElementType::Tet4) continue;
    converted[bi] = 1;
    const auto conn = b.conn;
    b.type = ElementType::Tet10;
    b.conn.resize(conn.rows(), 10);
    for (Eigen::Index r = 0; r < conn.rows(); ++r) {
      for (int j = 0; j < 4; ++j) b.conn(r, j) = conn(r, j);
      for (int e = 0; e < 6; ++e) b.conn(r, 4 + e) = middle.at(edge_key(conn(r, kEdge[e][0]), conn(r, kEdge[e][1])));
    }
  }
  // Node sets: a surface edge's middle joins every set holding both of its ends.
  for (auto& [name, v] : out.node_sets) {
    std::vector<char> in(static_cast<std::size_t>(n0), 0);
    for (int i : v) in[static_cast<std::size_t>(i)] = 1;
    for (Eigen::Index k = 0; k < added; ++k) {
      const auto [a, c] = ends[static_cast<std::size_t>(k)];
      if (surface[static_cast<std::size_t>(k)] && in[static_cast<std::size_t>(a)] && in[static_cast<std::size_t>(c)])
        v.push_back(static_cast<int>(n0 + k));
    }
  }
  // Curved placement of surface middles, undone where it folds a tetrahedron.
  std::size_t kept = 0;
  if (place) {
    std::vector<char> placed(static_cast<std::size_t>(added), 0);
    for (Eigen::Index k = 0; k < added; ++k) {
      if (!surface[static_cast<std::size_t>(k)]) continue;
      const auto [a, c] = ends[static_cast<std::size_t>(k)];
      const Eigen::Vector3d mid = out.nodes.row(n0 + k).transpose();
      const Eigen::Vector3d q = place(a, c, mid);
      // a node `place` leaves on the straight middle (within rounding of the edge) is not counted as moved
      if (!q.allFinite() || (q - mid).norm() <= 1e-9 * (m.nodes.row(a) - m.nodes.row(c)).norm()) continue;
      out.nodes.row(n0 + k) = q.transpose();
      placed[static_cast<std::size_t>(k)] = 1;
    }
    // Until nothing changes: a middle put back for one tetrahedron can fold a neighbour whose other
    // curved middles it balanced. Each pass only puts nodes back, so this ends.
    for (bool changed = true; changed;) {
      changed = false;
      for (std::size_t bi = 0; bi < out.blocks.size(); ++bi) {
        const ElementBlock& b = out.blocks[bi];
        if (!converted[bi]) continue;
        for (Eigen::Index r = 0; r < b.conn.rows(); ++r) {
          bool any = false;
          for (int j = 4; j < 10; ++j) any = any || (b.conn(r, j) >= n0 && placed[static_cast<std::size_t>(b.conn(r, j) - n0)]);
          if (!any || !folded(out, b, r)) continue;
          for (int j = 4; j < 10; ++j) {
            const Eigen::Index k = b.conn(r, j) - n0;  // < 0: a given block's middle, never moved here
            if (k >= 0 && placed[static_cast<std::size_t>(k)]) {
              const auto [a, c] = ends[static_cast<std::size_t>(k)];
              out.nodes.row(n0 + k) = 0.5 * (m.nodes.row(a) + m.nodes.row(c));
              placed[static_cast<std::size_t>(k)] = 0;
              changed = true;
            }
          }
        }
      }
    }
    for (char p : placed) kept += p != 0;
  }
  if (moved) *moved = kept;
  return out;
}

}  // namespace fe
