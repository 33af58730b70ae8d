// Writing Abaqus / CalculiX .inp (see write_inp in featureextract/femesh.h).
#include "femesh_detail.h"

namespace fe {

using namespace femesh_detail;

void write_inp(const FeMesh& m, const std::string& path) {
  check_mesh(m);
  File out(path);
  out.put("** FeatureExtract FE mesh\n*NODE\n");
  for (Eigen::Index i = 0; i < m.nodes.rows(); ++i) {
    out.num(node_id(m, static_cast<int>(i)));
    for (int c = 0; c < 3; ++c) {
      out.put(", ");
      out.num(m.nodes(i, c));
    }
    out.put("\n");
  }
  const std::vector<long> eids = element_ids(m);
  std::map<std::string, std::vector<int>> block_sets;  // what the *ELEMENT ELSET= parameters define
  int g = 0;
  for (const auto& b : m.blocks) {
    if (b.conn.rows() == 0) continue;
    out.put(std::string("*ELEMENT, TYPE=") + inp_type_name(b.type) + (b.elset.empty() ? "" : ", ELSET=" + inp_name(b.elset)) + "\n");
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r, ++g) {
      out.num(eids[static_cast<std::size_t>(g)]);
      for (Eigen::Index j = 0; j < b.conn.cols(); ++j) {
        out.put(", ");
        out.num(node_id(m, b.conn(r, j)));
      }
      out.put("\n");
      if (!b.elset.empty()) block_sets[b.elset].push_back(g);
    }
  }
  for (const auto& [name, v] : m.node_sets) {
    out.put("*NSET, NSET=" + inp_name(name) + "\n");
    std::vector<long> ids;
    for (int i : v) ids.push_back(node_id(m, i));
    write_id_list(out, ids);
  }
  for (const auto& [name, v] : m.element_sets) {
    std::vector<int> sorted = v;
    std::sort(sorted.begin(), sorted.end());
    sorted.erase(std::unique(sorted.begin(), sorted.end()), sorted.end());
    const auto it = block_sets.find(name);
    if (it != block_sets.end() && it->second == sorted) continue;  // already defined by *ELEMENT, ELSET=
    out.put("*ELSET, ELSET=" + inp_name(name) + "\n");
    std::vector<long> ids;
    for (int i : sorted) ids.push_back(eids[static_cast<std::size_t>(i)]);
    write_id_list(out, ids);
  }
  out.close();
}

}  // namespace fe
