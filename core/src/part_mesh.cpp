// One FE mesh of the whole part (issue 12): patches, the mesher's job, assembly, conformity, CalculiX deck.
#include "featureextract/part_mesh.h"

#include "featureextract/geometry.h"
#include "featureextract/mesh.h"
#include "featureextract/transfer.h"

#include "kdtree.h"

#include <boost/graph/adjacency_list.hpp>
#include <boost/graph/cuthill_mckee_ordering.hpp>
#include <nlohmann/json.hpp>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace fe {

namespace {

[[noreturn]] void bad_answer(const std::string& what) { throw InputError("fe_gmsh_rest: " + what); }

// Edges of the shell elements, as (lo, hi) node pairs, with the global element index of each use.
std::map<std::pair<int, int>, std::vector<int>> shell_edges(const FeMesh& m) {
  std::map<std::pair<int, int>, std::vector<int>> edges;
  int e = 0;
  for (const ElementBlock& b : m.blocks) {
    const int n = nodes_per_element(b.type);
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r, ++e) {
      if (!is_shell(b.type)) continue;
      for (int k = 0; k < n; ++k) {
        const int a = b.conn(r, k), c = b.conn(r, (k + 1) % n);
        edges[{std::min(a, c), std::max(a, c)}].push_back(e);
      }
    }
  }
  return edges;
}

double median_edge(const FeMesh& m) {
  std::vector<double> len;
  for (const auto& [edge, uses] : shell_edges(m)) len.push_back((m.nodes.row(edge.first) - m.nodes.row(edge.second)).norm());
  if (len.empty()) return 0;
  std::nth_element(len.begin(), len.begin() + static_cast<std::ptrdiff_t>(len.size() / 2), len.end());
  return len[len.size() / 2];
}

// The linear part of the transform the transfer added to the instance's specification (identity
// without one): its Jacobian at the target point `at` when given (a projective map's upper 3 x 3 alone
// is not its linear part away from the origin: CTC-02's fifth lug, whose perspective row is 0.01, read
// 6x its size), else its upper 3 x 3.
Eigen::Matrix3d instance_linear(const nlohmann::json& spec, const Eigen::Vector3d* at = nullptr) {
  if (!spec.is_object() || !spec.contains("transform") || !spec["transform"].is_array() || spec["transform"].size() != 4)
    return Eigen::Matrix3d::Identity();
  Eigen::Matrix4d H;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) H(r, c) = spec["transform"][static_cast<std::size_t>(r)][static_cast<std::size_t>(c)].get<double>();
  if (at && std::abs(H.determinant()) > 0) {
    const Eigen::Matrix3d J = transform_jacobian(H, apply_transform(H.inverse(), *at));
    if (J.allFinite()) return J;
  }
  return H.topLeftCorner<3, 3>();
}

// The linear part of the instance's transform where its placed patch lies (its nodes' mean): a
// projective fit's scale changes across the part, so its upper 3 x 3 alone can be far off.
Eigen::Matrix3d patch_linear(const nlohmann::json& spec, const FeMesh& patch) {
  if (patch.nodes.rows() == 0) return instance_linear(spec);
  const Eigen::Vector3d centroid = patch.nodes.colwise().mean().transpose();
  return instance_linear(spec, &centroid);
}

// The width of the specification's transition zone on this instance (its "transition_zone" rule's
// width times the instance's scale at its patch), 0 without one.
double transition_width(const std::string& spec_json, const FeMesh& patch) {
  const nlohmann::json spec = nlohmann::json::parse(spec_json, nullptr, false);
  if (!spec.is_object() || !spec.contains("rules") || !spec["rules"].is_array()) return 0;
  for (const auto& r : spec["rules"])
    if (r.is_object() && r.contains("rule") && r["rule"] == "transition_zone" && r.contains("width") && r["width"].is_number()) {
      const double w = r["width"].get<double>() * std::cbrt(std::abs(patch_linear(spec, patch).determinant()));
      return std::isfinite(w) && w > 0 ? w : 0;
    }
  return 0;
}

// The rest's triangles turned to agree with their neighbours across every shared edge (a shared edge
// runs one way in one element and the other way in the next), starting from the patches, whose
// orientation is the feature's (outward). gmsh orients a face's triangles by the face's parameters, not
// by the solid; CalculiX averages shell normals at a node and fails where they cancel. A rest region
// that touches no patch keeps its first triangle's turn, and all of it is turned if the closed part's
// signed volume comes out negative.
void orient_like_patches(FeMesh& m, int patch_elements) {
  struct Ref { std::size_t block; Eigen::Index row; };
  std::vector<Ref> el;
  for (std::size_t b = 0; b < m.blocks.size(); ++b)
    for (Eigen::Index r = 0; r < m.blocks[b].conn.rows(); ++r) el.push_back({b, r});
  const auto edges = shell_edges(m);
  auto runs = [&](int e, int a, int c) {  // +1 if element e runs a->c, -1 if c->a
    const ElementBlock& b = m.blocks[el[static_cast<std::size_t>(e)].block];
    const int n = nodes_per_element(b.type);
    const auto row = b.conn.row(el[static_cast<std::size_t>(e)].row);
    for (int k = 0; k < n; ++k) {
      if (row(k) == a && row((k + 1) % n) == c) return 1;
      if (row(k) == c && row((k + 1) % n) == a) return -1;
    }
    return 0;
  };
  auto flip = [&](int e) {
    ElementBlock& b = m.blocks[el[static_cast<std::size_t>(e)].block];
    auto row = b.conn.row(el[static_cast<std::size_t>(e)].row);
    const int n = nodes_per_element(b.type);
    for (int k = 1; k < (n + 1) / 2; ++k) std::swap(row(k), row(n - k));  // 0 2 1 / 0 3 2 1
  };
  std::vector<std::vector<std::pair<int, int>>> around(el.size());  // element -> its edges
  for (const auto& [edge, uses] : edges)
    for (const int e : uses) around[static_cast<std::size_t>(e)].push_back(edge);
  std::vector<char> done(el.size(), 0);
  std::vector<int> queue;
  auto spread = [&](std::vector<int> seeds) {
    std::vector<int> comp;
    for (const int s : seeds) done[static_cast<std::size_t>(s)] = 1;
    queue = seeds;
    while (!queue.empty()) {
      const int e = queue.back();
      queue.pop_back();
      comp.push_back(e);
      for (const auto& edge : around[static_cast<std::size_t>(e)]) {
        const auto& uses = edges.at(edge);
        if (uses.size() != 2) continue;  // free or non-manifold: no rule
        const int o = uses[0] == e ? uses[1] : uses[0];
        if (done[static_cast<std::size_t>(o)]) continue;
        if (runs(e, edge.first, edge.second) == runs(o, edge.first, edge.second)) flip(o);
        done[static_cast<std::size_t>(o)] = 1;
        queue.push_back(o);
      }
    }
    return comp;
  };
  std::vector<int> seeds;
  for (int e = 0; e < patch_elements && e < static_cast<int>(el.size()); ++e) seeds.push_back(e);
  if (!seeds.empty()) spread(seeds);
  for (int e = 0; e < static_cast<int>(el.size()); ++e) {
    if (done[static_cast<std::size_t>(e)] || !is_shell(m.blocks[el[static_cast<std::size_t>(e)].block].type)) continue;
    const std::vector<int> comp = spread({e});
    double vol = 0;  // signed volume of the region (meaningful when it is closed)
    for (const int c : comp) {
      const ElementBlock& b = m.blocks[el[static_cast<std::size_t>(c)].block];
      const auto row = b.conn.row(el[static_cast<std::size_t>(c)].row);
      const int n = nodes_per_element(b.type);
      const Eigen::Vector3d p0 = m.nodes.row(row(0)).transpose();
      for (int k = 1; k + 1 < n; ++k) {
        const Eigen::Vector3d p1 = m.nodes.row(row(k)).transpose(), p2 = m.nodes.row(row(k + 1)).transpose();
        vol += p0.dot(p1.cross(p2));
      }
    }
    if (vol < 0)
      for (const int c : comp) flip(c);
  }
}

// The answer's [tag, x, y, z] rows into m.nodes from row `first` on; tag -> row into *row_of.
void read_tagged_nodes(const nlohmann::json& rows, Eigen::Index first, FeMesh& m, std::unordered_map<long, int>* row_of,
                       const char* what) {
  Eigen::Index r = first;
  for (const auto& nd : rows) {
    if (!nd.is_array() || nd.size() != 4) bad_answer(std::string(what) + " is not [tag, x, y, z]");
    m.nodes.row(r) << nd[1].get<double>(), nd[2].get<double>(), nd[3].get<double>();
    (*row_of)[nd[0].get<long>()] = static_cast<int>(r++);
  }
}

// Nearest point of a triangle mesh: the closest point over the triangles of the 8 centroids nearest
// to the query (the triangulation is fine beside the elements that ask).
class SurfaceFoot {
 public:
  explicit SurfaceFoot(const TriangleMesh& s) : s_(s), tree_(centroids(s)) {}
  /// The nearest point; its triangle in *triangle (-1 for an empty mesh).
  Eigen::Vector3d operator()(const Eigen::Vector3d& q, int* triangle = nullptr) const {
    tree_.knn(q, 8, idx_, d2_);
    double best = INFINITY;
    Eigen::Vector3d out = q;
    if (triangle) *triangle = -1;
    for (const int t : idx_) {
      const Eigen::Vector3d f = closest_point_on_triangle(q, vertex(t, 0), vertex(t, 1), vertex(t, 2));
      if ((f - q).squaredNorm() < best) {
        best = (f - q).squaredNorm();
        out = f;
        if (triangle) *triangle = t;
      }
    }
    return out;
  }

 private:
  static Points centroids(const TriangleMesh& s) {
    Points c(s.triangles.rows(), 3);
    for (Eigen::Index t = 0; t < s.triangles.rows(); ++t)
      c.row(t) = (s.vertices.row(s.triangles(t, 0)) + s.vertices.row(s.triangles(t, 1)) + s.vertices.row(s.triangles(t, 2))) / 3;
    return c;
  }
  Eigen::Vector3d vertex(int t, int k) const { return s_.vertices.row(s_.triangles(t, k)).transpose(); }
  const TriangleMesh& s_;
  KdTree3 tree_;
  mutable std::vector<int> idx_;
  mutable std::vector<float> d2_;
};

}  // namespace

std::string set_name(const std::string& text) {
  std::string o;
  for (const unsigned char c : text) {
    if (std::isalnum(c)) o += static_cast<char>(std::toupper(c));
    else if (!o.empty() && o.back() != '_') o += '_';
  }
  while (!o.empty() && o.back() == '_') o.pop_back();
  return o.empty() ? "FEATURE" : o;
}

std::vector<int> border_nodes(const FeMesh& m) {
  std::set<int> out;
  for (const auto& [edge, uses] : shell_edges(m))
    if (uses.size() == 1) {
      out.insert(edge.first);
      out.insert(edge.second);
    }
  return {out.begin(), out.end()};
}

std::vector<std::string> resolve_overlaps(std::vector<PartPatch>& patches) {
  std::vector<std::size_t> order(patches.size());
  for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return patches[a].score > patches[b].score; });
  std::map<int, std::size_t> owner;  // face -> kept patch
  std::vector<bool> keep(patches.size(), true);
  std::vector<std::string> lines;
  for (const std::size_t i : order) {
    std::size_t other = patches.size();
    for (const int f : patches[i].faces)
      if (auto it = owner.find(f); it != owner.end()) {
        other = it->second;
        break;
      }
    if (other < patches.size()) {
      keep[i] = false;
      std::ostringstream s;
      s << patches[i].name << " (score " << patches[i].score << ") shares faces with " << patches[other].name << " (score "
        << patches[other].score << "): left out";
      lines.push_back(s.str());
      continue;
    }
    for (const int f : patches[i].faces) owner[f] = i;
  }
  std::vector<PartPatch> kept;
  for (std::size_t i = 0; i < patches.size(); ++i)
    if (keep[i]) kept.push_back(std::move(patches[i]));
  patches = std::move(kept);
  return lines;
}

void keep_elements(FeMesh& m, const std::vector<char>& keep) {
  std::vector<int> new_element(keep.size(), -1);
  std::vector<char> used(static_cast<std::size_t>(m.nodes.rows()), 0);
  int e = 0, kept = 0;
  for (ElementBlock& b : m.blocks) {
    const int n = nodes_per_element(b.type);
    std::vector<Eigen::Index> rows;
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r, ++e)
      if (static_cast<std::size_t>(e) < keep.size() && keep[static_cast<std::size_t>(e)]) {
        rows.push_back(r);
        new_element[static_cast<std::size_t>(e)] = kept++;
        for (int k = 0; k < n; ++k) used[static_cast<std::size_t>(b.conn(r, k))] = 1;
      }
    decltype(b.conn) conn(static_cast<Eigen::Index>(rows.size()), n);
    std::vector<long> ids;
    for (std::size_t i = 0; i < rows.size(); ++i) {
      conn.row(static_cast<Eigen::Index>(i)) = b.conn.row(rows[i]);
      if (!b.ids.empty()) ids.push_back(b.ids[static_cast<std::size_t>(rows[i])]);
    }
    b.conn = std::move(conn);
    b.ids = std::move(ids);
  }
  m.blocks.erase(std::remove_if(m.blocks.begin(), m.blocks.end(), [](const ElementBlock& b) { return b.conn.rows() == 0; }),
                 m.blocks.end());
  std::vector<int> new_node(used.size(), -1);
  int nn = 0;
  for (std::size_t v = 0; v < used.size(); ++v)
    if (used[v]) new_node[v] = nn++;
  Points nodes(nn, 3);
  std::vector<long> node_ids;
  for (std::size_t v = 0; v < used.size(); ++v)
    if (used[v]) {
      nodes.row(new_node[v]) = m.nodes.row(static_cast<Eigen::Index>(v));
      if (!m.node_ids.empty()) node_ids.push_back(m.node_ids[v]);
    }
  for (ElementBlock& b : m.blocks)
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r)
      for (Eigen::Index k = 0; k < b.conn.cols(); ++k) b.conn(r, k) = new_node[static_cast<std::size_t>(b.conn(r, k))];
  m.nodes = std::move(nodes);
  m.node_ids = std::move(node_ids);
  auto renumber = [](std::vector<int>& members, const std::vector<int>& to) {
    std::vector<int> out;
    for (const int i : members)
      if (i >= 0 && static_cast<std::size_t>(i) < to.size() && to[static_cast<std::size_t>(i)] >= 0) out.push_back(to[static_cast<std::size_t>(i)]);
    members = std::move(out);  // the maps keep the order, so sorted stays sorted
  };
  for (auto& [name, members] : m.node_sets) renumber(members, new_node);
  for (auto& [name, members] : m.element_sets) renumber(members, new_element);
}

namespace {

// Triangles with a bounding sphere each: the exact nearest of them to a point, skipping most (a
// B-rep's triangles can be long strips, so the nearest centroid says little about the nearest triangle).
class NearestTriangle {
 public:
  void add(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, int tag) {
    const Eigen::Vector3d m = (a + b + c) / 3;
    tris_.push_back({a, b, c, m, std::max({(a - m).norm(), (b - m).norm(), (c - m).norm()}), tag});
  }
  bool empty() const { return tris_.empty(); }
  /// The tag of the nearest triangle among those `among` allows (all: null), 0 if none; distance in *dist.
  int operator()(const Eigen::Vector3d& q, const std::set<int>* among, double* dist) const {
    double best = INFINITY;
    int tag = 0;
    for (const Tri& t : tris_) {
      if (among && !among->count(t.tag)) continue;
      const double lower = (q - t.centre).norm() - t.radius;
      if (lower > 0 && lower * lower >= best) continue;
      const double d2 = (closest_point_on_triangle(q, t.a, t.b, t.c) - q).squaredNorm();
      if (d2 < best) best = d2, tag = t.tag;
    }
    if (dist) *dist = std::sqrt(best);
    return tag;
  }

 private:
  struct Tri { Eigen::Vector3d a, b, c, centre; double radius; int tag; };
  std::vector<Tri> tris_;
};

}  // namespace

ClaimReport claim_covered_faces(PartPatch& p, const TriangleMesh& part, double min_share) {
  ClaimReport out;
  if (p.faces.empty() || !part.from_brep() || p.mesh.num_elements() == 0) return out;
  const double h = median_edge(p.mesh);
  if (!(h > 0)) return out;
  // the patch's shell elements as triangles
  NearestTriangle patch;
  std::vector<Eigen::Vector3d> centroid;
  for (const ElementBlock& b : p.mesh.blocks) {
    const int n = nodes_per_element(b.type);
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r) {
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (int k = 0; k < n; ++k) c += p.mesh.nodes.row(b.conn(r, k)).transpose();
      centroid.push_back(c / n);
      if (!is_shell(b.type)) continue;
      for (int k = 1; k + 1 < n; ++k)
        patch.add(p.mesh.nodes.row(b.conn(r, 0)).transpose(), p.mesh.nodes.row(b.conn(r, k)).transpose(),
                  p.mesh.nodes.row(b.conn(r, k + 1)).transpose(), 1);
    }
  }
  if (patch.empty()) return out;
  // each listed face's share under the patch: points of its triangles, about an edge of the patch
  // apart, within half an edge of the patch's elements (a narrow fillet the elements span counts
  // whole; a face the patch only borders, the strip along that border)
  const std::set<int> listed(p.faces.begin(), p.faces.end());
  std::map<int, double> area, covered;
  NearestTriangle faces;
  for (Eigen::Index t = 0; t < part.triangles.rows(); ++t) {
    const int f = part.face_ids(t);
    if (!listed.count(f)) continue;
    const Eigen::Vector3d a = part.vertices.row(part.triangles(t, 0)), b = part.vertices.row(part.triangles(t, 1)),
                          c = part.vertices.row(part.triangles(t, 2));
    faces.add(a, b, c, f);
    const double ar = 0.5 * (b - a).cross(c - a).norm();
    const int m = std::clamp(static_cast<int>(std::ceil(std::max({(b - a).norm(), (c - b).norm(), (a - c).norm()}) / h)), 1, 24);
    int near = 0;
    for (int i = 0; i < m; ++i)
      for (int j = 0; i + j < m; ++j) {  // the centroids of the m x m sub-triangles pointing up
        const double u = (i + 1.0 / 3) / m, v = (j + 1.0 / 3) / m;
        double d;
        patch(a + u * (b - a) + v * (c - a), nullptr, &d);
        near += d <= 1.5 * h;
      }
    area[f] += ar;
    covered[f] += ar * near / (m * (m + 1) / 2.0);
  }
  std::vector<int> kept;
  for (const int f : p.faces)
    if (area[f] > 0 && covered[f] < min_share * area[f]) out.dropped_faces.push_back(f);
    else kept.push_back(f);
  if (out.dropped_faces.empty()) return out;
  p.faces = kept;
  // an element goes if it lies on a dropped face: its centroid nearest one, and farther than half an
  // edge from the kept faces; one that only reaches over their edge (a fit a hair off) stays, and the
  // mesher puts its border nodes onto that edge
  const std::set<int> dropped(out.dropped_faces.begin(), out.dropped_faces.end()), keep_faces(kept.begin(), kept.end());
  std::vector<char> keep(centroid.size(), 1);
  for (std::size_t e = 0; e < centroid.size(); ++e) {
    if (!dropped.count(faces(centroid[e], nullptr, nullptr))) continue;
    double d = INFINITY;
    if (!keep_faces.empty()) faces(centroid[e], &keep_faces, &d);
    if (d > 0.5 * h) {
      keep[e] = 0;
      ++out.removed_elements;
    }
  }
  if (out.removed_elements) {
    keep_elements(p.mesh, keep);
    if (p.reference_scaled_jacobian.size() == keep.size()) {
      std::vector<double> sj;
      for (std::size_t e = 0; e < keep.size(); ++e)
        if (keep[e]) sj.push_back(p.reference_scaled_jacobian[e]);
      p.reference_scaled_jacobian = std::move(sj);
    }
  }
  return out;
}

std::string part_mesh_job(const std::string& part_path, int part_faces, double size, const std::vector<PartPatch>& patches,
                          bool plain, double tolerance_factor, const std::vector<Eigen::Vector3d>& face_centroids) {
  nlohmann::json j;
  j["part"] = part_path;
  j["face_centroids"] = nlohmann::json::array();
  for (const auto& c : face_centroids)
    j["face_centroids"].push_back(c.allFinite() ? nlohmann::json{c.x(), c.y(), c.z()} : nlohmann::json(nullptr));
  j["plain"] = plain;
  j["faces"] = part_faces;
  j["size"] = size;
  j["patches"] = nlohmann::json::array();
  long key = 0;
  for (const PartPatch& p : patches) {
    nlohmann::json pj;
    pj["faces"] = p.faces;
    pj["tolerance"] = tolerance_factor * median_edge(p.mesh);
    if (const double w = transition_width(p.spec_json, p.mesh); w > 0 && !plain) pj["transition"] = {{"width", w}, {"size", median_edge(p.mesh)}};
    pj["nodes"] = nlohmann::json::array();
    for (Eigen::Index i = 0; i < p.mesh.nodes.rows(); ++i)
      pj["nodes"].push_back({key + i, p.mesh.nodes(i, 0), p.mesh.nodes(i, 1), p.mesh.nodes(i, 2)});
    pj["border"] = nlohmann::json::array();
    for (const int b : border_nodes(p.mesh)) pj["border"].push_back(key + b);
    pj["border_edges"] = nlohmann::json::array();  // the border's chain: which border nodes are joined
    for (const auto& [edge, uses] : shell_edges(p.mesh))
      if (uses.size() == 1) pj["border_edges"].push_back({key + edge.first, key + edge.second});
    pj["rigid"] = nlohmann::json::object();
    for (const std::string& r : p.rigid_sets) {
      // rigid_sets hold the assembled names (NAME_SET); the patch's own set is SET
      const std::string own = r.substr(std::min(r.size(), p.name.size() + 1));
      if (const auto it = p.mesh.node_sets.find(own); it != p.mesh.node_sets.end()) {
        auto& keys = pj["rigid"][r];
        for (const int v : it->second) keys.push_back(key + v);
      }
    }
    key += p.mesh.nodes.rows();
    j["patches"].push_back(std::move(pj));
  }
  return j.dump();
}

void conformity(const FeMesh& m, double tolerance, std::size_t* free_edges, std::size_t* duplicate_nodes,
                std::vector<int>* free_edge_elements) {
  if (free_edges || free_edge_elements) {
    std::size_t n = 0;
    std::set<int> els;
    for (const auto& [edge, uses] : shell_edges(m))
      if (uses.size() == 1) {
        ++n;
        els.insert(uses[0]);
      }
    if (free_edges) *free_edges = n;
    if (free_edge_elements) free_edge_elements->assign(els.begin(), els.end());
  }
  if (duplicate_nodes) {
    // nodes sorted along x; a pair closer than tolerance is within tolerance in x
    const Eigen::Index n = m.nodes.rows();
    std::vector<Eigen::Index> order(static_cast<std::size_t>(n));
    for (Eigen::Index i = 0; i < n; ++i) order[static_cast<std::size_t>(i)] = i;
    std::sort(order.begin(), order.end(), [&](Eigen::Index a, Eigen::Index b) { return m.nodes(a, 0) < m.nodes(b, 0); });
    std::set<Eigen::Index> dup;
    for (std::size_t a = 0; a < order.size(); ++a)
      for (std::size_t b = a + 1; b < order.size() && m.nodes(order[b], 0) - m.nodes(order[a], 0) <= tolerance; ++b)
        if ((m.nodes.row(order[a]) - m.nodes.row(order[b])).norm() <= tolerance) dup.insert(order[b]);
    *duplicate_nodes = dup.size();
  }
}

FeMesh assemble_part_mesh(const std::vector<PartPatch>& patches, const std::string& rest_json, PartMeshReport* report) {
  const nlohmann::json j = nlohmann::json::parse(rest_json, nullptr, false);
  if (j.is_discarded() || !j.is_object()) bad_answer("its answer is not a JSON object");
  for (const char* k : {"nodes", "triangles", "joined", "moved"})
    if (!j.contains(k) || !j[k].is_array()) bad_answer(std::string("its answer has no \"") + k + "\" list");
  PartMeshReport rep;
  FeMesh out;
  long total = 0;
  for (const PartPatch& p : patches) total += p.mesh.nodes.rows();
  const long rest_n = static_cast<long>(j["nodes"].size());
  out.nodes.resize(total + rest_n, 3);
  out.node_ids.resize(static_cast<std::size_t>(total + rest_n));
  for (long i = 0; i < total + rest_n; ++i) out.node_ids[static_cast<std::size_t>(i)] = i + 1;
  long base = 0;
  long next_element = 1;
  for (const PartPatch& p : patches) {
    out.nodes.middleRows(base, p.mesh.nodes.rows()) = p.mesh.nodes;
    const std::string pre = p.name + "_";
    std::vector<int> mine;
    const int first_element = static_cast<int>(out.num_elements());
    for (const ElementBlock& b : p.mesh.blocks) {
      ElementBlock nb = b;
      nb.conn.array() += static_cast<int>(base);
      nb.elset = b.elset.empty() ? p.name : pre + b.elset;
      for (auto& id : nb.ids) id = next_element++;
      out.blocks.push_back(std::move(nb));
    }
    const int n_el = static_cast<int>(p.mesh.num_elements());
    for (const auto& [name, members] : p.mesh.element_sets) {
      auto& s = out.element_sets[pre + name];
      for (const int e : members) s.push_back(first_element + e);
    }
    auto& all = out.element_sets[p.name];
    for (int e = 0; e < n_el; ++e) all.push_back(first_element + e);
    for (const auto& [name, members] : p.mesh.node_sets) {
      auto& s = out.node_sets[pre + name];
      for (const int v : members) s.push_back(static_cast<int>(base) + v);
    }
    rep.patch_nodes += static_cast<std::size_t>(p.mesh.nodes.rows());
    rep.patch_elements += p.mesh.num_elements();
    base += p.mesh.nodes.rows();
  }
  rep.patches = patches.size();
  // patch nodes put onto the B-rep
  for (const auto& mv : j["moved"]) {
    if (!mv.is_array() || mv.size() != 4) bad_answer("a \"moved\" entry is not [key, x, y, z]");
    const long k = mv[0].get<long>();
    if (k < 0 || k >= total) bad_answer("a moved node's key " + std::to_string(k) + " is not a patch node");
    out.nodes.row(k) << mv[1].get<double>(), mv[2].get<double>(), mv[3].get<double>();
    ++rep.moved_nodes;
  }
  // the rest's nodes: gmsh tag -> row
  std::unordered_map<long, int> row_of;
  read_tagged_nodes(j["nodes"], total, out, &row_of, "a node");
  for (const auto& jn : j["joined"]) {
    const long k = jn[1].get<long>();
    if (k < 0 || k >= total) bad_answer("a joined node's key " + std::to_string(k) + " is not a patch node");
    row_of[jn[0].get<long>()] = static_cast<int>(k);
    ++rep.joined_nodes;
  }
  ElementBlock rest;
  rest.type = ElementType::Tri3;
  rest.elset = "PART_REST";
  rest.conn.resize(static_cast<Eigen::Index>(j["triangles"].size()), 3);
  Eigen::Index t = 0;
  for (const auto& tri : j["triangles"]) {
    if (!tri.is_array() || tri.size() != 4) bad_answer("a triangle is not [face, n1, n2, n3]");
    for (int k = 0; k < 3; ++k) {
      const auto it = row_of.find(tri[static_cast<std::size_t>(k + 1)].get<long>());
      if (it == row_of.end()) bad_answer("a triangle uses node " + std::to_string(tri[static_cast<std::size_t>(k + 1)].get<long>()) + ", which it does not list");
      rest.conn(t, k) = it->second;
    }
    rest.ids.push_back(next_element++);
    ++t;
  }
  rep.rest_nodes = static_cast<std::size_t>(rest_n);
  rep.rest_elements = static_cast<std::size_t>(rest.conn.rows());
  if (rest.conn.rows() > 0) {
    const int first = static_cast<int>(out.num_elements());
    auto& s = out.element_sets["PART_REST"];
    for (Eigen::Index e = 0; e < rest.conn.rows(); ++e) s.push_back(first + static_cast<int>(e));
    out.blocks.push_back(std::move(rest));
  }
  orient_like_patches(out, static_cast<int>(rep.patch_elements));
  // support
  std::vector<int> fixed;
  if (j.contains("fixed_nodes"))
    for (const auto& tg : j["fixed_nodes"])
      if (auto it = row_of.find(tg.get<long>()); it != row_of.end()) fixed.push_back(it->second);
  if (j.contains("fixed_keys"))
    for (const auto& k : j["fixed_keys"])
      if (k.get<long>() >= 0 && k.get<long>() < total) fixed.push_back(static_cast<int>(k.get<long>()));
  if (j.contains("rigid_nodes") && j["rigid_nodes"].is_object())  // a plain mesh's bolt faces
    for (const auto& [name, tags] : j["rigid_nodes"].items()) {
      auto& s = out.node_sets[name];
      for (const auto& tg : tags)
        if (auto it = row_of.find(tg.get<long>()); it != row_of.end()) s.push_back(it->second);
    }
  std::sort(fixed.begin(), fixed.end());
  fixed.erase(std::unique(fixed.begin(), fixed.end()), fixed.end());
  if (!fixed.empty()) out.node_sets["FIXED"] = fixed;
  for (auto& [name, s] : out.node_sets) {
    std::sort(s.begin(), s.end());
    s.erase(std::unique(s.begin(), s.end()), s.end());
  }
  rep.fixed_face = j.value("fixed_face", 0);
  if (j.contains("report")) rep.mesher_report = j["report"].dump();
  // conformity: border nodes left out, free edges, duplicates
  std::set<long> joined_keys;
  for (const auto& jn : j["joined"]) joined_keys.insert(jn[1].get<long>());
  base = 0;
  for (const PartPatch& p : patches) {
    for (const int b : border_nodes(p.mesh))
      if (!joined_keys.count(base + b)) ++rep.border_nodes_not_joined;
    base += p.mesh.nodes.rows();
  }
  const Eigen::Vector3d lo = out.nodes.colwise().minCoeff(), hi = out.nodes.colwise().maxCoeff();
  std::vector<int> free_els;
  conformity(out, 1e-9 * std::max(1.0, (hi - lo).norm()), &rep.free_edges, &rep.duplicate_nodes, &free_els);
  for (const int e : free_els)
    if (e < static_cast<int>(rep.patch_elements)) ++rep.free_edges_at_patches;
  if (report) *report = rep;
  return out;
}

// A quad of the surface is cut into two triangles across its shorter diagonal: 0-2 (true) or 1-3.
// fill_job cuts it so, and quadratic_solid takes that diagonal, and only that one, as a surface edge.
namespace {
template <class Row>
bool cut_02(const FeMesh& surface, const Row& c) {
  return (surface.nodes.row(c(0)) - surface.nodes.row(c(2))).norm() <= (surface.nodes.row(c(1)) - surface.nodes.row(c(3))).norm();
}
}  // namespace

std::string fill_job(const FeMesh& surface, double size) {
  nlohmann::json j;
  j["fill"] = true;
  j["size"] = size;
  j["nodes"] = nlohmann::json::array();
  for (Eigen::Index i = 0; i < surface.nodes.rows(); ++i)
    j["nodes"].push_back({i + 1, surface.nodes(i, 0), surface.nodes(i, 1), surface.nodes(i, 2)});
  j["triangles"] = nlohmann::json::array();
  for (const ElementBlock& b : surface.blocks) {
    if (!is_shell(b.type)) continue;
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r) {
      const auto c = b.conn.row(r);
      if (b.type == ElementType::Tri3) {
        j["triangles"].push_back({c(0) + 1, c(1) + 1, c(2) + 1});
        continue;
      }
      if (cut_02(surface, c)) {
        j["triangles"].push_back({c(0) + 1, c(1) + 1, c(2) + 1});
        j["triangles"].push_back({c(0) + 1, c(2) + 1, c(3) + 1});
      } else {
        j["triangles"].push_back({c(0) + 1, c(1) + 1, c(3) + 1});
        j["triangles"].push_back({c(1) + 1, c(2) + 1, c(3) + 1});
      }
    }
  }
  return j.dump();
}

FeMesh solid_from_fill(const FeMesh& surface, const std::string& fill_json) {
  const nlohmann::json j = nlohmann::json::parse(fill_json, nullptr, false);
  if (j.is_discarded() || !j.is_object() || !j.contains("nodes") || !j.contains("tets") || !j["tets"].is_array())
    bad_answer("its tetrahedra answer is not {\"nodes\": [...], \"tets\": [...]}");
  FeMesh out;
  const Eigen::Index n0 = surface.nodes.rows();
  out.nodes.resize(n0 + static_cast<Eigen::Index>(j["nodes"].size()), 3);
  out.nodes.topRows(n0) = surface.nodes;
  std::unordered_map<long, int> inner;
  read_tagged_nodes(j["nodes"], n0, out, &inner, "an inner node");
  out.node_ids.resize(static_cast<std::size_t>(out.nodes.rows()));
  for (Eigen::Index i = 0; i < out.nodes.rows(); ++i) out.node_ids[static_cast<std::size_t>(i)] = i + 1;
  ElementBlock b;
  b.type = ElementType::Tet4;
  b.elset = "PART_SOLID";
  b.conn.resize(static_cast<Eigen::Index>(j["tets"].size()), 4);
  Eigen::Index t = 0;
  for (const auto& tet : j["tets"]) {
    if (!tet.is_array() || tet.size() != 4) bad_answer("a tetrahedron is not [n1, n2, n3, n4]");
    for (int k = 0; k < 4; ++k) {
      const long v = tet[static_cast<std::size_t>(k)].get<long>();
      if (v > 0 && v <= n0) b.conn(t, k) = static_cast<int>(v - 1);
      else if (auto it = inner.find(-v); v < 0 && it != inner.end()) b.conn(t, k) = it->second;
      else bad_answer("a tetrahedron uses node " + std::to_string(v) + ", which is neither a surface node nor listed");
    }
    // positive volume (femesh.h's convention)
    const Eigen::Vector3d p0 = out.nodes.row(b.conn(t, 0)).transpose(), p1 = out.nodes.row(b.conn(t, 1)).transpose(),
                          p2 = out.nodes.row(b.conn(t, 2)).transpose(), p3 = out.nodes.row(b.conn(t, 3)).transpose();
    if ((p1 - p0).cross(p2 - p0).dot(p3 - p0) < 0) std::swap(b.conn(t, 1), b.conn(t, 2));
    b.ids.push_back(static_cast<long>(t + 1));
    ++t;
  }
  out.element_sets["PART_SOLID"].resize(static_cast<std::size_t>(t));
  for (Eigen::Index e = 0; e < t; ++e) out.element_sets["PART_SOLID"][static_cast<std::size_t>(e)] = static_cast<int>(e);
  out.blocks.push_back(std::move(b));
  out.node_sets = surface.node_sets;  // the surface nodes keep their rows
  return out;
}

FeMesh quadratic_solid(const FeMesh& solid, const FeMesh& surface, const TriangleMesh& part, std::size_t* on_part,
                       const FaceProjector& onto_faces, std::size_t* on_brep) {
  // surface edges: the surface elements' edges, and the diagonal fill_job cut each quad across
  std::set<std::pair<int, int>> edges;
  auto add = [&](int a, int b) { edges.insert({std::min(a, b), std::max(a, b)}); };
  for (const ElementBlock& b : surface.blocks) {
    if (!is_shell(b.type)) continue;
    const int k = nodes_per_element(b.type);
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r) {
      for (int j = 0; j < k; ++j) add(b.conn(r, j), b.conn(r, (j + 1) % k));
      if (k == 4) cut_02(surface, b.conn.row(r)) ? add(b.conn(r, 0), b.conn(r, 2)) : add(b.conn(r, 1), b.conn(r, 3));
    }
  }
  const auto on_surface = [&](int a, int b) { return edges.count({std::min(a, b), std::max(a, b)}) > 0; };
  if (on_brep) *on_brep = 0;
  if (part.triangles.rows() == 0) return to_quadratic(solid, on_surface, {}, on_part);
  // Each surface edge's middle: its foot on the triangulation, then (a B-rep part) on the exact face
  // of that foot's triangle. Farther than a quarter of the edge: another wall of a thin part, not this
  // face, and the middle stays straight.
  const SurfaceFoot foot(part);
  std::map<std::pair<int, int>, Eigen::Vector3d> at;
  std::vector<std::pair<int, int>> asked;
  std::vector<int> faces;
  Points feet(static_cast<Eigen::Index>(edges.size()), 3);
  for (const auto& [a, b] : edges) {
    const Eigen::Vector3d mid = 0.5 * (solid.nodes.row(a) + solid.nodes.row(b)).transpose();
    int t = -1;
    const Eigen::Vector3d f = foot(mid, &t);
    if ((f - mid).norm() > 0.25 * (solid.nodes.row(a) - solid.nodes.row(b)).norm()) continue;
    at[{a, b}] = f;
    const int face = t >= 0 && t < part.face_ids.size() ? part.face_ids(t) : 0;
    if (onto_faces && face > 0) {
      feet.row(static_cast<Eigen::Index>(asked.size())) = f.transpose();
      asked.push_back({a, b});
      faces.push_back(face);
    }
  }
  if (!asked.empty()) {
    feet.conservativeResize(static_cast<Eigen::Index>(asked.size()), 3);
    Points moved = feet;
    onto_faces(moved, faces);
    for (std::size_t i = 0; i < asked.size(); ++i) {
      const auto [a, b] = asked[i];
      const Eigen::Vector3d q = moved.row(static_cast<Eigen::Index>(i)).transpose();
      const Eigen::Vector3d mid = 0.5 * (solid.nodes.row(a) + solid.nodes.row(b)).transpose();
      const double len = (solid.nodes.row(a) - solid.nodes.row(b)).norm();
      if (!q.allFinite() || (q - mid).norm() > 0.25 * len) continue;
      if (on_brep && (q - at[{a, b}]).norm() > 1e-6 * len) ++*on_brep;  // not a rounding move on a plane
      at[{a, b}] = q;
    }
  }
  const auto place = [&](int a, int b, const Eigen::Vector3d& mid) -> Eigen::Vector3d {
    const auto it = at.find({std::min(a, b), std::max(a, b)});
    return it == at.end() ? mid : it->second;
  };
  return to_quadratic(solid, on_surface, place, on_part);
}

RepairReport repair_patches(FeMesh& m, std::size_t patch_elements, const TriangleMesh& surface, const std::vector<int>& locked,
                            double min_scaled_jacobian, int passes, const std::vector<NodeAxis>& on_circles) {
  RepairReport rep;
  if (surface.triangles.rows() == 0 || patch_elements == 0) return rep;
  const SurfaceFoot foot(surface);
  // elements of the patches: rows, and which way the surface's normal counts as outward for them
  struct El { std::size_t block; Eigen::Index row; };
  std::vector<El> els;
  for (std::size_t b = 0; b < m.blocks.size() && els.size() < patch_elements; ++b)
    for (Eigen::Index r = 0; r < m.blocks[b].conn.rows() && els.size() < patch_elements; ++r) els.push_back({b, r});
  const std::size_t ne = m.num_elements();
  // which way is out, per element: the mean normal of its neighbours across its edges (the mesh is
  // turned consistently; an element folded over has a normal against theirs). The part's triangles
  // cannot tell: BRepMesh turns them by face.
  const Points own = element_normals(m);
  Points ref = Points::Zero(static_cast<Eigen::Index>(ne), 3);
  {
    const auto edges = shell_edges(m);
    for (const auto& [edge, uses] : edges)
      for (const int e : uses)
        for (const int o : uses)
          if (o != e && static_cast<std::size_t>(e) < els.size()) ref.row(e) += own.row(o);
    for (std::size_t e = 0; e < els.size(); ++e) {
      const double n = ref.row(static_cast<Eigen::Index>(e)).norm();
      if (n > 0) ref.row(static_cast<Eigen::Index>(e)) /= n;
    }
  }
  // node -> its patch elements, node -> neighbours along element edges
  std::vector<std::vector<int>> node_els(static_cast<std::size_t>(m.nodes.rows())), nbr(static_cast<std::size_t>(m.nodes.rows()));
  for (std::size_t e = 0; e < els.size(); ++e) {
    const auto row = m.blocks[els[e].block].conn.row(els[e].row);
    const int n = static_cast<int>(row.size());
    for (int k = 0; k < n; ++k) {
      node_els[static_cast<std::size_t>(row(k))].push_back(static_cast<int>(e));
      nbr[static_cast<std::size_t>(row(k))].push_back(row((k + 1) % n));
      nbr[static_cast<std::size_t>(row(k))].push_back(row((k + n - 1) % n));
    }
  }
  std::map<int, int> axis_of;  // node -> its axis (rule nodes_on_circles)
  for (std::size_t a = 0; a < on_circles.size(); ++a)
    for (const int v : on_circles[a].nodes) axis_of[v] = static_cast<int>(a);
  std::vector<char> is_locked(static_cast<std::size_t>(m.nodes.rows()), 0);
  for (const int v : locked)
    if (v >= 0 && v < m.nodes.rows()) is_locked[static_cast<std::size_t>(v)] = 1;
  // per element the worse of its scaled Jacobian against its neighbours' normal (a fold) and against
  // its own (what the quality goal and the solver see); inverted as judged against the neighbours
  auto q_all = [&]() {
    std::vector<ElementQuality> against = element_quality(m, &ref);
    const std::vector<ElementQuality> own = element_quality(m);
    for (std::size_t e = 0; e < against.size() && e < own.size(); ++e)
      against[e].scaled_jacobian = std::min(against[e].scaled_jacobian, own[e].scaled_jacobian);
    return against;
  };
  std::vector<ElementQuality> q = q_all();
  auto count_bad = [&](const std::vector<ElementQuality>& qq, std::size_t* inv) {
    std::size_t bad = 0, iv = 0;
    for (std::size_t e = 0; e < els.size(); ++e) {
      bad += qq[e].scaled_jacobian < min_scaled_jacobian;
      iv += qq[e].inverted;
    }
    if (inv) *inv = iv;
    return bad;
  };
  rep.poor_before = count_bad(q, &rep.inverted_before);
  // the worst scaled Jacobian among a node's elements with the node where it now is, each element
  // measured both against its neighbours' normal (a fold shows) and against its own (as the quality
  // goal and the solver see it)
  auto local_worst = [&](int v) {
    double w = INFINITY;
    for (const int e : node_els[static_cast<std::size_t>(v)]) {
      FeMesh one;  // one element, its own nodes
      const auto& blk = m.blocks[els[static_cast<std::size_t>(e)].block];
      const auto row = blk.conn.row(els[static_cast<std::size_t>(e)].row);
      one.nodes.resize(row.size(), 3);
      ElementBlock b1;
      b1.type = blk.type;
      b1.conn.resize(1, row.size());
      for (Eigen::Index k = 0; k < row.size(); ++k) {
        one.nodes.row(k) = m.nodes.row(row(k));
        b1.conn(0, k) = static_cast<int>(k);
      }
      one.blocks.push_back(b1);
      Points r1 = ref.row(e);
      w = std::min({w, element_quality(one, &r1)[0].scaled_jacobian, element_quality(one)[0].scaled_jacobian});
    }
    return w;
  };
  // how far the node's edges leave the part: the largest distance of an edge's middle from the
  // surface, over the edge's length. A move may not round off a sharp edge of the part (a node on a
  // rib's top edge slid onto its side) or cut across a fillet: it must keep this under
  // max(1 %, 1.25 x what it was).
  auto sag = [&](int v) {
    double w = 0;
    const Eigen::Vector3d p = m.nodes.row(v).transpose();
    for (const int u : nbr[static_cast<std::size_t>(v)]) {
      const Eigen::Vector3d mid = 0.5 * (p + m.nodes.row(u).transpose());
      const double len = (p - m.nodes.row(u).transpose()).norm();
      if (len > 0) w = std::max(w, (foot(mid) - mid).norm() / len);
    }
    return w;
  };
  // a trial position onto the part, a node under nodes_on_circles turned back to its angle about the
  // axis (a surface of revolution about it keeps the point on itself)
  auto onto = [&](int v, const Eigen::Vector3d& old, const Eigen::Vector3d& p) -> Eigen::Vector3d {
    Eigen::Vector3d to = foot(p);
    if (const auto it = axis_of.find(v); it != axis_of.end()) {
      const NodeAxis& ax = on_circles[static_cast<std::size_t>(it->second)];
      const Eigen::Vector3d d = ax.direction.normalized();
      const Eigen::Vector3d r0 = (old - ax.point) - (old - ax.point).dot(d) * d, r1 = (to - ax.point) - (to - ax.point).dot(d) * d;
      if (r0.norm() > 0 && r1.norm() > 0) to = ax.point + (to - ax.point).dot(d) * d + r1.norm() * r0.normalized();
    }
    return to;
  };
  std::set<int> moved;
  for (int pass = 0; pass < passes; ++pass) {
    std::set<int> cand;
    for (std::size_t e = 0; e < els.size(); ++e)
      if (q[e].scaled_jacobian < min_scaled_jacobian) {
        const auto row = m.blocks[els[e].block].conn.row(els[e].row);
        for (Eigen::Index k = 0; k < row.size(); ++k)
          if (!is_locked[static_cast<std::size_t>(row(k))]) cand.insert(row(k));
      }
    if (cand.empty()) break;
    ++rep.passes;
    bool any = false;
    for (const int v : cand) {
      const auto& nb = nbr[static_cast<std::size_t>(v)];
      if (nb.empty()) continue;
      Eigen::Vector3d avg = Eigen::Vector3d::Zero();
      double edge = 0;
      const Eigen::Vector3d old = m.nodes.row(v).transpose();
      for (const int u : nb) {
        avg += m.nodes.row(u).transpose();
        edge += (m.nodes.row(u).transpose() - old).norm();
      }
      avg /= static_cast<double>(nb.size());
      edge /= static_cast<double>(nb.size());
      const double before = local_worst(v), sag_limit = std::max(0.01, 1.25 * sag(v));
      Eigen::Vector3d best = old;
      double best_q = before;
      auto trial = [&](const Eigen::Vector3d& p) {
        const Eigen::Vector3d to = onto(v, old, p);
        m.nodes.row(v) = to.transpose();
        const double w = local_worst(v);
        if (w > best_q + 1e-9 && sag(v) <= sag_limit) {
          best_q = w;
          best = to;
          return true;
        }
        return false;
      };
      // Laplacian steps toward the neighbours' mean, then a pattern search in the tangent plane that
      // raises the worst element around the node (optimization-based smoothing: it finds a better
      // place where the mean is itself a poor one, next to a locked border or on a curved face)
      for (const double t : {1.0, 0.5, 0.25}) trial(old + t * (avg - old));
      Eigen::Vector3d n = Eigen::Vector3d::Zero();
      for (const int e : node_els[static_cast<std::size_t>(v)]) n += ref.row(e).transpose();
      if (n.norm() > 0 && edge > 0) {
        n.normalize();
        const Eigen::Vector3d e1 = n.unitOrthogonal(), e2 = n.cross(e1);
        double h = 0.2 * edge;
        for (int it = 0; it < 40 && h > 0.005 * edge; ++it) {
          const Eigen::Vector3d from = best;
          bool better = false;
          for (int k = 0; k < 8; ++k) {
            const double a = k * 0.7853981633974483;
            better = trial(from + h * (std::cos(a) * e1 + std::sin(a) * e2)) || better;
          }
          if (!better) h *= 0.5;
        }
      }
      m.nodes.row(v) = best.transpose();
      if (best_q > before + 1e-9) {
        moved.insert(v);
        any = true;
      }
    }
    q = q_all();
    if (!any) break;
  }
  rep.moved_nodes = moved.size();
  rep.poor_after = count_bad(q, &rep.inverted_after);
  return rep;
}

std::string check_rules(const FeMesh& patch, const std::string& spec_json) {
  const nlohmann::json spec = nlohmann::json::parse(spec_json, nullptr, false);
  nlohmann::json out = nlohmann::json::array();
  if (!spec.is_object() || !spec.contains("rules") || !spec["rules"].is_array()) return out.dump();
  // the instance's scale and the reference +x direction, from the transform's Jacobian at the patch
  const Eigen::Matrix3d A = patch_linear(spec, patch);
  const double scale = std::cbrt(std::abs(A.determinant()));
  const double size = spec.contains("element") && spec["element"].is_object() && spec["element"].contains("size") &&
                              spec["element"]["size"].is_number() ? spec["element"]["size"].get<double>() : 0.0;
  std::vector<double> len;
  for (const auto& [edge, uses] : shell_edges(patch)) len.push_back((patch.nodes.row(edge.first) - patch.nodes.row(edge.second)).norm());
  std::sort(len.begin(), len.end());
  for (const auto& rule : spec["rules"]) {
    if (!rule.is_object() || !rule.contains("rule") || !rule["rule"].is_string()) continue;
    const std::string name = rule["rule"].get<std::string>();
    nlohmann::json r = {{"rule", name}};
    if (name == "nodes_on_circles" && spec.contains("axis") && spec["axis"].is_object()) {
      const auto& ax = spec["axis"];
      Eigen::Vector3d c(ax["point"][0].get<double>(), ax["point"][1].get<double>(), ax["point"][2].get<double>());
      Eigen::Vector3d d(ax["direction"][0].get<double>(), ax["direction"][1].get<double>(), ax["direction"][2].get<double>());
      d.normalize();
      // the axis through the patch's centroid (its rings are whole turns, so the centroid is on the
      // axis): once on the B-rep the nodes circle the part's own axis, which the fit's mapped one
      // misses by a little (0.16 mm on the example plate's larger boss, 1 degree at its root)
      if (patch.nodes.rows() > 0) {
        const Eigen::Vector3d g = patch.nodes.colwise().mean().transpose();
        c += (g - c) - (g - c).dot(d) * d;
      }
      // angle 0: the reference's +x, mapped, across the axis (a mirror image turns the other way)
      Eigen::Vector3d e1 = A.col(0) - A.col(0).dot(d) * d;
      e1.normalize();
      Eigen::Vector3d e2 = d.cross(e1);
      if (A.determinant() < 0) e2 = -e2;
      const double step = rule.value("angle_step_deg", 30.0), start = rule.value("start_angle_deg", 0.0);
      double worst = 0;
      std::size_t off = 0, nodes = 0;
      for (Eigen::Index i = 0; i < patch.nodes.rows(); ++i) {
        const Eigen::Vector3d q = patch.nodes.row(i).transpose() - c;
        const double x = q.dot(e1), y = q.dot(e2);
        if (std::hypot(x, y) < 0.05 * std::max(size * scale, 1e-9)) continue;  // on the axis
        ++nodes;
        double a = std::atan2(y, x) * 180.0 / M_PI - start;
        a = std::fmod(std::fmod(a, step) + step, step);
        const double dev = std::min(a, step - a);
        worst = std::max(worst, dev);
        off += dev > 1.0;
      }
      r["nodes"] = nodes;
      r["max_angle_error_deg"] = worst;
      r["nodes_off_by_more_than_1_deg"] = off;
      r["ok"] = off == 0;
    } else if (name == "element_size" && size > 0 && !len.empty()) {
      const double median = len[len.size() / 2];
      r["size"] = size * scale;
      r["median_edge"] = median;
      r["ratio"] = median / (size * scale);
      r["ok"] = r["ratio"].get<double>() > 0.7 && r["ratio"].get<double>() < 1.3;
    } else if (name == "quad_dominant") {
      std::size_t quads = 0, all = 0;
      for (const ElementBlock& b : patch.blocks) {
        all += static_cast<std::size_t>(b.conn.rows());
        if (b.type == ElementType::Quad4) quads += static_cast<std::size_t>(b.conn.rows());
      }
      r["quad_fraction"] = all ? static_cast<double>(quads) / static_cast<double>(all) : 0.0;
      r["ok"] = r["quad_fraction"].get<double>() >= 0.5;
    } else {
      r["ok"] = nullptr;  // not checked
      r["why"] = "no check for this rule";
    }
    out.push_back(r);
  }
  return out.dump();
}

std::string check_transition(const FeMesh& whole, std::size_t patch_elements, const FeMesh& patch, const std::string& spec_json,
                             double rest_size) {
  const double width = transition_width(spec_json, patch);
  if (!(width > 0)) return "";
  const double small = median_edge(patch);
  nlohmann::json r = {{"rule", "transition_zone"}, {"width", width}, {"from_size", small}, {"to_size", rest_size}};
  const std::vector<int> border = border_nodes(patch);
  Points bp(static_cast<Eigen::Index>(border.size()), 3);
  for (std::size_t i = 0; i < border.size(); ++i) bp.row(static_cast<Eigen::Index>(i)) = patch.nodes.row(border[i]);
  std::vector<double> ratios;
  if (bp.rows() > 0 && rest_size > 0) {
    const KdTree3 tree(bp);
    std::size_t g = 0;
    for (const ElementBlock& b : whole.blocks) {
      const int k = nodes_per_element(b.type);
      for (Eigen::Index e = 0; e < b.conn.rows(); ++e, ++g) {
        if (g < patch_elements || !is_shell(b.type)) continue;
        Eigen::Vector3d c = Eigen::Vector3d::Zero();
        double edges = 0;
        for (int j = 0; j < k; ++j) {
          c += whole.nodes.row(b.conn(e, j)).transpose();
          edges += (whole.nodes.row(b.conn(e, j)) - whole.nodes.row(b.conn(e, (j + 1) % k))).norm();
        }
        c /= k;
        double d2 = 0;
        if (tree.nearest(c, &d2) < 0) continue;
        const double d = std::sqrt(d2);
        if (d >= width) continue;
        const double want = std::min(rest_size, small + (rest_size - small) * d / width);
        ratios.push_back(edges / k / want);
      }
    }
  }
  std::sort(ratios.begin(), ratios.end());
  const std::size_t within = static_cast<std::size_t>(std::upper_bound(ratios.begin(), ratios.end(), 1.5) - ratios.begin());
  r["elements"] = ratios.size();
  r["median_ratio"] = ratios.empty() ? 0.0 : ratios[ratios.size() / 2];
  r["max_ratio"] = ratios.empty() ? 0.0 : ratios.back();
  r["share_within_1.5"] = ratios.empty() ? 0.0 : static_cast<double>(within) / static_cast<double>(ratios.size());
  r["ok"] = !ratios.empty() && r["share_within_1.5"].get<double>() >= 0.9;
  r["text"] = "elements of the rest within the width of the instance's border: mean edge over the size the zone asks there";
  return r.dump();
}

void number_nodes_for_solver(FeMesh& m) {
  using Graph = boost::adjacency_list<boost::vecS, boost::vecS, boost::undirectedS,
                                      boost::property<boost::vertex_color_t, boost::default_color_type, boost::property<boost::vertex_degree_t, int>>>;
  const int n = static_cast<int>(m.nodes.rows());
  std::vector<std::pair<int, int>> edges;
  for (const ElementBlock& b : m.blocks)
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r)
      for (Eigen::Index i = 0; i < b.conn.cols(); ++i)
        for (Eigen::Index k = i + 1; k < b.conn.cols(); ++k) {
          const int u = b.conn(r, i), v = b.conn(r, k);
          if (u != v) edges.emplace_back(std::min(u, v), std::max(u, v));
        }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  Graph g(edges.begin(), edges.end(), static_cast<Graph::vertices_size_type>(n));
  std::vector<Graph::vertex_descriptor> order(static_cast<std::size_t>(n));
  // every connected component, each from a pseudo-peripheral node; the reverse order
  boost::cuthill_mckee_ordering(g, order.rbegin(), boost::get(boost::vertex_color, g), boost::make_degree_map(g));
  m.node_ids.assign(static_cast<std::size_t>(n), 0);
  for (std::size_t k = 0; k < order.size(); ++k) m.node_ids[order[k]] = static_cast<long>(k) + 1;
}

void write_ccx_static(const FeMesh& m, const std::string& mesh_file, const StaticAnalysis& a, const std::string& path) {
  std::ofstream o(path);
  if (!o) throw std::runtime_error(path + ": cannot write");
  char buf[256];
  o << "** Linear static analysis written by featureextract mesh-part (CalculiX ccx)\n";
  o << "*INCLUDE, INPUT=" << mesh_file << "\n";
  long next = 0;
  for (const long id : m.node_ids) next = std::max(next, id);
  std::vector<std::pair<std::string, long>> refs;
  for (const std::string& s : a.rigid_sets) {
    const auto it = m.node_sets.find(s);
    if (it == m.node_sets.end() || it->second.empty()) continue;
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const int v : it->second) c += m.nodes.row(v).transpose();
    c /= static_cast<double>(it->second.size());
    refs.emplace_back(s, ++next);
    o << "*NODE, NSET=REF_" << s << "\n";
    std::snprintf(buf, sizeof(buf), "%ld, %.17g, %.17g, %.17g\n", next, c.x(), c.y(), c.z());
    o << buf;
  }
  long lo = m.node_ids.empty() ? 1 : *std::min_element(m.node_ids.begin(), m.node_ids.end());
  long hi = m.node_ids.empty() ? 0 : *std::max_element(m.node_ids.begin(), m.node_ids.end());
  if (hi - lo + 1 == static_cast<long>(m.node_ids.size()))
    o << "*NSET, NSET=PART_NODES, GENERATE\n" << lo << ", " << hi << ", 1\n";
  else
    throw std::invalid_argument(path + ": node ids must be contiguous");
  o << "*MATERIAL, NAME=STEEL\n*ELASTIC\n";
  std::snprintf(buf, sizeof(buf), "%.17g, %.17g\n", a.young, a.poisson);
  o << buf;
  // one section per element set of the partition (each patch's set, PART_REST)
  std::snprintf(buf, sizeof(buf), "%.17g\n", a.thickness);
  for (const std::string& s : a.section_sets) {
    if (a.solid) o << "*SOLID SECTION, ELSET=" << s << ", MATERIAL=STEEL\n";
    else o << "*SHELL SECTION, ELSET=" << s << ", MATERIAL=STEEL\n" << buf;
  }
  for (const auto& [s, ref] : refs) o << "*RIGID BODY, NSET=" << s << ", REF NODE=" << ref << "\n";
  o << "*BOUNDARY\n" << a.fixed_set << (a.solid ? ", 1, 3\n" : ", 1, 6\n");
  o << "*STEP\n*STATIC\n";
  if (!refs.empty()) {
    o << "*CLOAD\n";
    const Eigen::Vector3d d = a.direction.normalized() * a.force;
    for (const auto& [s, ref] : refs)
      for (int k = 0; k < 3; ++k)
        if (d(k) != 0) {
          std::snprintf(buf, sizeof(buf), "%ld, %d, %.17g\n", ref, k + 1, d(k));
          o << buf;
        }
  }
  for (const auto& [s, ref] : refs) o << "*NODE PRINT, NSET=REF_" << s << "\nU\n";
  o << "*NODE PRINT, NSET=PART_NODES\nU\n*NODE FILE\nU\n*EL FILE\nS\n*END STEP\n";
  if (!o) throw std::runtime_error(path + ": cannot write");
}

}  // namespace fe
