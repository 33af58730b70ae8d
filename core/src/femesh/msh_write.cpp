// Writing gmsh .msh 4.1 ASCII (see write_msh in featureextract/femesh.h).
#include "femesh_detail.h"

#include <limits>
#include <set>

namespace fe {

using namespace femesh_detail;

void write_msh(const FeMesh& m, const std::string& path) {
  check_mesh(m);
  const std::vector<long> eids = element_ids(m);
  const auto esets = all_element_sets(m);
  std::vector<std::string> enames;
  for (const auto& kv : esets) enames.push_back(kv.first);
  std::vector<std::string> nnames;
  for (const auto& kv : m.node_sets) nnames.push_back(kv.first);

  // Per element: its type, dimension and physical tags (1-based position in enames), block elset first.
  struct ElemRef {
    ElementType type;
    int block;
    Eigen::Index row;
  };
  std::vector<ElemRef> refs;
  for (std::size_t bi = 0; bi < m.blocks.size(); ++bi)
    for (Eigen::Index r = 0; r < m.blocks[bi].conn.rows(); ++r) refs.push_back({m.blocks[bi].type, static_cast<int>(bi), r});
  std::vector<std::vector<int>> member(refs.size());
  for (std::size_t s = 0; s < enames.size(); ++s)
    for (int g : esets.at(enames[s])) member[static_cast<std::size_t>(g)].push_back(static_cast<int>(s) + 1);
  for (std::size_t g = 0; g < refs.size(); ++g) {
    const std::string& elset = m.blocks[static_cast<std::size_t>(refs[g].block)].elset;
    if (elset.empty()) continue;
    const int tag = static_cast<int>(std::find(enames.begin(), enames.end(), elset) - enames.begin()) + 1;
    auto& v = member[g];
    v.erase(std::find(v.begin(), v.end(), tag));
    v.insert(v.begin(), tag);
  }
  // Entities: one per (dimension, physical tags), in order of first appearance; tags numbered per dimension.
  struct Entity {
    int dim, tag;
    std::vector<int> phys;
    Eigen::Vector3d lo, hi;
    std::vector<std::vector<std::size_t>> by_type{5};  // global element indices per ElementType
  };
  std::vector<Entity> entities;
  std::map<std::pair<int, std::vector<int>>, std::size_t> entity_of;
  int next_tag[4] = {1, 1, 1, 1};
  std::set<std::pair<int, int>> used_phys;  // (dim, tag)
  for (std::size_t g = 0; g < refs.size(); ++g) {
    const int dim = is_shell(refs[g].type) ? 2 : 3;
    auto key = std::make_pair(dim, member[g]);
    auto it = entity_of.find(key);
    if (it == entity_of.end()) {
      Entity e;
      e.dim = dim;
      e.tag = next_tag[dim]++;
      e.phys = member[g];
      e.lo.setConstant(std::numeric_limits<double>::infinity());
      e.hi.setConstant(-std::numeric_limits<double>::infinity());
      for (int p : e.phys) used_phys.insert({dim, p});
      it = entity_of.emplace(std::move(key), entities.size()).first;
      entities.push_back(std::move(e));
    }
    Entity& e = entities[it->second];
    e.by_type[static_cast<std::size_t>(refs[g].type)].push_back(g);
    const auto& b = m.blocks[static_cast<std::size_t>(refs[g].block)];
    for (Eigen::Index j = 0; j < b.conn.cols(); ++j) {
      const Eigen::Vector3d p = m.nodes.row(b.conn(refs[g].row, j)).transpose();
      e.lo = e.lo.cwiseMin(p);
      e.hi = e.hi.cwiseMax(p);
    }
  }
  if (entities.empty()) {  // nodes only: they still need an entity
    Entity e;
    e.dim = 3;
    e.tag = next_tag[3]++;
    e.lo = m.nodes.rows() ? Eigen::Vector3d(m.nodes.colwise().minCoeff().transpose()) : Eigen::Vector3d::Zero();
    e.hi = m.nodes.rows() ? Eigen::Vector3d(m.nodes.colwise().maxCoeff().transpose()) : Eigen::Vector3d::Zero();
    entities.push_back(std::move(e));
  }
  // Point entities: one per node in some node set, carrying the node sets' physical tags.
  std::vector<std::vector<int>> node_member(static_cast<std::size_t>(m.nodes.rows()));
  for (std::size_t s = 0; s < nnames.size(); ++s)
    for (int i : m.node_sets.at(nnames[s])) {
      auto& v = node_member[static_cast<std::size_t>(i)];
      if (v.empty() || v.back() != static_cast<int>(s) + 1) v.push_back(static_cast<int>(s) + 1);
    }
  std::vector<int> point_nodes;
  for (std::size_t i = 0; i < node_member.size(); ++i)
    if (!node_member[i].empty()) point_nodes.push_back(static_cast<int>(i));

  File out(path);
  out.put("$MeshFormat\n4.1 0 8\n$EndMeshFormat\n");
  // Physical names: element sets in the dimensions they occur in (an empty set as dimension 2), node sets as dimension 0.
  std::vector<std::string> phys_lines;
  auto quoted = [](const std::string& s) {
    std::string r = s;
    std::replace(r.begin(), r.end(), '"', '\'');
    return "\"" + r + "\"";
  };
  for (std::size_t s = 0; s < enames.size(); ++s) {
    const int tag = static_cast<int>(s) + 1;
    bool any = false;
    for (int dim : {2, 3})
      if (used_phys.count({dim, tag})) {
        phys_lines.push_back(std::to_string(dim) + " " + std::to_string(tag) + " " + quoted(enames[s]));
        any = true;
      }
    if (!any) phys_lines.push_back("2 " + std::to_string(tag) + " " + quoted(enames[s]));
  }
  for (std::size_t s = 0; s < nnames.size(); ++s) phys_lines.push_back("0 " + std::to_string(s + 1) + " " + quoted(nnames[s]));
  if (!phys_lines.empty()) {
    out.put("$PhysicalNames\n" + std::to_string(phys_lines.size()) + "\n");
    for (const auto& l : phys_lines) out.put(l + "\n");
    out.put("$EndPhysicalNames\n");
  }
  // Entities
  std::size_t count[4] = {point_nodes.size(), 0, 0, 0};
  for (const auto& e : entities) ++count[e.dim];
  out.put("$Entities\n" + std::to_string(count[0]) + " 0 " + std::to_string(count[2]) + " " + std::to_string(count[3]) + "\n");
  auto phys_list = [&](const std::vector<int>& phys) {
    out.put(" " + std::to_string(phys.size()));
    for (int p : phys) out.put(" " + std::to_string(p));
  };
  for (std::size_t k = 0; k < point_nodes.size(); ++k) {
    out.num(static_cast<long>(k) + 1);
    for (int c = 0; c < 3; ++c) {
      out.put(" ");
      out.num(m.nodes(point_nodes[k], c));
    }
    phys_list(node_member[static_cast<std::size_t>(point_nodes[k])]);
    out.put("\n");
  }
  for (int dim : {2, 3})
    for (const auto& e : entities) {
      if (e.dim != dim) continue;
      out.num(static_cast<long>(e.tag));
      for (int c = 0; c < 3; ++c) {
        out.put(" ");
        out.num(e.lo[c]);
      }
      for (int c = 0; c < 3; ++c) {
        out.put(" ");
        out.num(e.hi[c]);
      }
      phys_list(e.phys);
      out.put(" 0\n");
    }
  out.put("$EndEntities\n");
  // Nodes: all in one block on the first entity (gmsh looks element nodes up by tag).
  const long nn = static_cast<long>(m.nodes.rows());
  long min_node = 0, max_node = 0;
  for (long i = 0; i < nn; ++i) {
    const long id = node_id(m, static_cast<int>(i));
    min_node = i == 0 ? id : std::min(min_node, id);
    max_node = i == 0 ? id : std::max(max_node, id);
  }
  out.put("$Nodes\n" + std::string(nn ? "1 " : "0 ") + std::to_string(nn) + " " + std::to_string(min_node) + " " + std::to_string(max_node) + "\n");
  if (nn) {
    out.put(std::to_string(entities[0].dim) + " " + std::to_string(entities[0].tag) + " 0 " + std::to_string(nn) + "\n");
    for (long i = 0; i < nn; ++i) {
      out.num(node_id(m, static_cast<int>(i)));
      out.put("\n");
    }
    for (long i = 0; i < nn; ++i) {
      for (int c = 0; c < 3; ++c) {
        if (c) out.put(" ");
        out.num(m.nodes(i, c));
      }
      out.put("\n");
    }
  }
  out.put("$EndNodes\n");
  // Elements: per entity and type; then one point element per point entity, tags after the largest element id.
  static const int gmsh_type[5] = {2, 3, 4, 5, 11};  // per ElementType
  long max_eid = 0, min_eid = 0;
  for (std::size_t g = 0; g < eids.size(); ++g) {
    max_eid = g == 0 ? eids[g] : std::max(max_eid, eids[g]);
    min_eid = g == 0 ? eids[g] : std::min(min_eid, eids[g]);
  }
  std::size_t nblocks = point_nodes.size();
  for (const auto& e : entities)
    for (const auto& v : e.by_type) nblocks += !v.empty();
  const std::size_t nelem = eids.size() + point_nodes.size();
  if (eids.empty()) min_eid = 1;
  const long max_tag = point_nodes.empty() ? max_eid : max_eid + static_cast<long>(point_nodes.size());
  out.put("$Elements\n" + std::to_string(nblocks) + " " + std::to_string(nelem) + " " + std::to_string(nelem ? min_eid : 0) + " " +
          std::to_string(nelem ? max_tag : 0) + "\n");
  for (int dim : {2, 3})
    for (const auto& e : entities) {
      if (e.dim != dim) continue;
      for (int t = 0; t < 5; ++t) {
        const auto& v = e.by_type[static_cast<std::size_t>(t)];
        if (v.empty()) continue;
        out.put(std::to_string(e.dim) + " " + std::to_string(e.tag) + " " + std::to_string(gmsh_type[t]) + " " + std::to_string(v.size()) + "\n");
        for (std::size_t g : v) {
          const auto& b = m.blocks[static_cast<std::size_t>(refs[g].block)];
          out.num(eids[g]);
          for (Eigen::Index j = 0; j < b.conn.cols(); ++j) {
            // gmsh's 10-node tetrahedron lists the middle of edge 23 before that of edge 13
            const Eigen::Index k = b.type == ElementType::Tet10 && j >= 8 ? 17 - j : j;
            out.put(" ");
            out.num(node_id(m, b.conn(refs[g].row, k)));
          }
          out.put("\n");
        }
      }
    }
  for (std::size_t k = 0; k < point_nodes.size(); ++k)
    out.put("0 " + std::to_string(k + 1) + " 15 1\n" + std::to_string(max_eid + static_cast<long>(k) + 1) + " " +
            std::to_string(node_id(m, point_nodes[k])) + "\n");
  out.put("$EndElements\n");
  out.close();
}

}  // namespace fe
