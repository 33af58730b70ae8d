// Reading gmsh .msh, ASCII 2.x and 4.1 (see read_fe_mesh in featureextract/femesh.h).
#include "femesh_detail.h"

namespace fe::femesh_detail {

class Lexer {
 public:
  Lexer(const std::string& path, const std::string& data) : path_(path), s_(data) {}
  int line() const { return line_; }
  bool next(std::string_view& tok) {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) {
      if (s_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= s_.size()) return false;
    tok_line_ = line_;
    if (s_[pos_] == '"') {
      const std::size_t end = s_.find('"', pos_ + 1);
      if (end == std::string::npos) fail(path_, "line " + std::to_string(line_) + ": unterminated quoted name");
      tok = std::string_view(s_).substr(pos_ + 1, end - pos_ - 1);
      for (std::size_t i = pos_; i < end; ++i) line_ += s_[i] == '\n';
      pos_ = end + 1;
      return true;
    }
    const std::size_t start = pos_;
    while (pos_ < s_.size() && !std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
    tok = std::string_view(s_).substr(start, pos_ - start);
    return true;
  }
  std::string_view need(const char* what) {
    std::string_view t;
    if (!next(t)) fail(path_, "line " + std::to_string(line_) + ": unexpected end of file, expected " + what + " (truncated?)");
    return t;
  }
  long need_long(const char* what) {
    const std::string_view t = need(what);
    long v;
    if (!parse_long(t, v)) error(std::string("expected ") + what + ", found '" + excerpt(t) + "'");
    return v;
  }
  long need_count(const char* what) {
    const long v = need_long(what);
    if (v < 0) error(std::string("negative ") + what);
    return v;
  }
  double need_double(const char* what) {
    const std::string_view t = need(what);
    double v;
    if (!parse_double(t, v)) error(std::string("expected ") + what + ", found '" + excerpt(t) + "'");
    return v;
  }
  void expect(const char* keyword) {
    const std::string_view t = need(keyword);
    if (t != keyword) error(std::string("expected ") + keyword + ", found '" + excerpt(t) + "'");
  }
  [[noreturn]] void error(const std::string& what) const { fail(path_, "line " + std::to_string(tok_line_) + ": " + what); }

 private:
  const std::string& path_;
  const std::string& s_;
  std::size_t pos_ = 0;
  int line_ = 1, tok_line_ = 1;
};

// gmsh element type -> node count (0: unsupported). Types 1 (line) and 15 (point) only feed node sets.
int gmsh_nodes(long type) {
  switch (type) {
    case 1: return 2;
    case 2: return 3;
    case 3: return 4;
    case 4: return 4;
    case 5: return 8;
    case 11: return 10;
    case 15: return 1;
    default: return 0;
  }
}

const char* gmsh_type_name(long type) {
  switch (type) {
    case 6: return "6-node prism";
    case 7: return "5-node pyramid";
    case 8: return "3-node line";
    case 9: return "6-node triangle";
    case 10: return "9-node quadrangle";
    case 11: return "10-node tetrahedron";
    case 12: return "27-node hexahedron";
    case 16: return "8-node quadrangle";
    case 17: return "20-node hexahedron";
    default: return "";
  }
}

FeMesh read_msh(const std::string& path) {
  const std::string data = read_all(path);
  Lexer lx(path, data);
  Builder b;
  b.path = path;
  b.files.push_back(path);

  std::string_view tok = lx.need("$MeshFormat");
  if (tok != "$MeshFormat") lx.error("not a gmsh .msh file (no $MeshFormat header, found '" + excerpt(tok) + "')");
  const std::string version(lx.need("version"));
  int major = 0;
  if (version == "2" || version == "2.0" || version == "2.1" || version == "2.2") major = 2;
  else if (version == "4.1") major = 4;
  else lx.error("unsupported .msh version " + excerpt(version) + " (ASCII 2.2 and 4.1 are supported)");
  if (lx.need_long("file type") != 0) lx.error("binary .msh is not supported (save as ASCII)");
  lx.need("data size");
  lx.expect("$EndMeshFormat");

  std::map<std::pair<int, long>, std::string> phys_names;
  std::map<std::pair<int, long>, std::vector<long>> entity_phys;  // 4.1: (dim, entity) -> physical tags
  auto phys_name = [&](int dim, long tag) {
    const auto it = phys_names.find({dim, tag});
    return it != phys_names.end() ? it->second : "Physical" + std::to_string(dim) + "D_" + std::to_string(tag);
  };
  struct Elem {
    ElementType type;
    long id;
    std::array<long, 10> nodes;
    std::vector<std::string> names;
    Builder::Loc loc;
  };
  std::vector<Elem> elems;
  std::unordered_map<long, std::size_t> elem_pos;
  bool have_nodes = false, have_elements = false;

  // msh 2 writes an element once per physical group, with a new id: (type, elementary tag, nodes) identifies it.
  std::map<std::pair<std::array<long, 2>, std::vector<long>>, std::size_t> v2_elem;

  auto add_elem = [&](long type, long id, const long* nodes, std::vector<std::string> names, int line, long elementary) {
    const int k = gmsh_nodes(type);
    if (type == 1 || type == 15) {  // lower-dimensional: nodes into the node sets of its physical groups
      for (const auto& name : names) {
        auto& s = b.nset(name);
        for (int j = 0; j < k; ++j) {
          s.ids.push_back(nodes[j]);
          s.locs.push_back(Builder::loc(0, line));
        }
      }
      return;
    }
    const ElementType t = type == 2 ? ElementType::Tri3 : type == 3 ? ElementType::Quad4 : type == 4 ? ElementType::Tet4
                        : type == 11 ? ElementType::Tet10 : ElementType::Hex8;
    long tet10[10];
    if (t == ElementType::Tet10) {  // gmsh lists the middle of edge 23 before that of edge 13; Abaqus after
      std::copy(nodes, nodes + 10, tet10);
      std::swap(tet10[8], tet10[9]);
      nodes = tet10;
    }
    auto merge = [&](Elem& e) {
      for (auto& n : names)
        if (std::find(e.names.begin(), e.names.end(), n) == e.names.end()) e.names.push_back(std::move(n));
    };
    const auto it = elem_pos.find(id);
    if (it != elem_pos.end()) {  // same id repeated for another physical group
      Elem& e = elems[it->second];
      if (e.type != t || !std::equal(nodes, nodes + k, e.nodes.begin())) lx.error("duplicate element id " + std::to_string(id));
      return merge(e);
    }
    if (major == 2) {
      const auto ins = v2_elem.emplace(std::make_pair(std::array<long, 2>{type, elementary}, std::vector<long>(nodes, nodes + k)), elems.size());
      if (!ins.second) return merge(elems[ins.first->second]);
    }
    Elem e{t, id, {}, std::move(names), Builder::loc(0, line)};
    std::copy(nodes, nodes + k, e.nodes.begin());
    elem_pos.emplace(id, elems.size());
    elems.push_back(std::move(e));
  };
  auto check_type = [&](long type) {
    if (gmsh_nodes(type) == 0) {
      const std::string name = gmsh_type_name(type);
      lx.error("unsupported gmsh element type " + std::to_string(type) + (name.empty() ? "" : " (" + name + ")") +
               "; supported: 2 (triangle), 3 (quadrangle), 4 (tetrahedron), 5 (hexahedron), 11 (10-node tetrahedron), points and lines for node sets");
    }
  };

  while (lx.next(tok)) {
    if (tok.empty() || tok[0] != '$') lx.error("expected a $Section, found '" + excerpt(tok) + "'");
    const std::string section(tok.substr(1));
    if (section == "PhysicalNames") {
      const long n = lx.need_count("number of physical names");
      for (long i = 0; i < n; ++i) {
        const long dim = lx.need_long("physical dimension");
        const long tag = lx.need_long("physical tag");
        const std::string name(lx.need("physical name"));
        if (dim < 0 || dim > 3) lx.error("bad physical dimension " + std::to_string(dim));
        phys_names[{static_cast<int>(dim), tag}] = name;
      }
    } else if (section == "Entities" && major == 4) {
      long counts[4];
      for (long& c : counts) c = lx.need_count("number of entities");
      for (int dim = 0; dim < 4; ++dim) {
        for (long i = 0; i < counts[dim]; ++i) {
          const long tag = lx.need_long("entity tag");
          for (int j = 0; j < (dim == 0 ? 3 : 6); ++j) lx.need_double("entity coordinate");
          const long np = lx.need_count("number of physical tags");
          auto& phys = entity_phys[{dim, tag}];
          for (long j = 0; j < np; ++j) phys.push_back(lx.need_long("physical tag"));
          if (dim > 0) {
            const long nb = lx.need_count("number of bounding entities");
            for (long j = 0; j < nb; ++j) lx.need_long("bounding entity tag");
          }
        }
      }
    } else if (section == "Nodes") {
      have_nodes = true;
      if (major == 2) {
        const long n = lx.need_count("number of nodes");
        for (long i = 0; i < n; ++i) {
          const long id = lx.need_long("node tag");
          const int line = lx.line();
          const double x = lx.need_double("x"), y = lx.need_double("y"), z = lx.need_double("z");
          b.add_node(id, x, y, z, Builder::loc(0, line));
        }
      } else {
        const long blocks = lx.need_count("number of node blocks");
        lx.need_count("number of nodes");
        lx.need_long("min node tag");
        lx.need_long("max node tag");
        for (long bi = 0; bi < blocks; ++bi) {
          const long dim = lx.need_long("entity dimension");
          lx.need_long("entity tag");
          const long parametric = lx.need_long("parametric flag");
          const long n = lx.need_count("number of nodes in block");
          if (dim < 0 || dim > 3) lx.error("bad entity dimension " + std::to_string(dim));
          std::vector<long> ids;
          for (long i = 0; i < n; ++i) ids.push_back(lx.need_long("node tag"));
          for (long i = 0; i < n; ++i) {
            const int line = lx.line();
            const double x = lx.need_double("x"), y = lx.need_double("y"), z = lx.need_double("z");
            for (long j = 0; parametric != 0 && j < dim; ++j) lx.need_double("parametric coordinate");
            b.add_node(ids[static_cast<std::size_t>(i)], x, y, z, Builder::loc(0, line));
          }
        }
      }
    } else if (section == "Elements") {
      have_elements = true;
      long nodes[10];
      if (major == 2) {
        const long n = lx.need_count("number of elements");
        for (long i = 0; i < n; ++i) {
          const long id = lx.need_long("element tag");
          const int line = lx.line();
          const long type = lx.need_long("element type");
          check_type(type);
          const long ntags = lx.need_count("number of tags");
          long physical = 0, elementary = 0;
          for (long j = 0; j < ntags; ++j) {
            const long t = lx.need_long("element tag value");
            if (j == 0) physical = t;
            if (j == 1) elementary = t;
          }
          for (int j = 0; j < gmsh_nodes(type); ++j) nodes[j] = lx.need_long("element node tag");
          const int dim = type == 15 ? 0 : type == 1 ? 1 : type <= 3 ? 2 : 3;
          std::vector<std::string> names;
          if (physical != 0) names.push_back(phys_name(dim, physical));
          add_elem(type, id, nodes, std::move(names), line, elementary);
        }
      } else {
        const long blocks = lx.need_count("number of element blocks");
        lx.need_count("number of elements");
        lx.need_long("min element tag");
        lx.need_long("max element tag");
        for (long bi = 0; bi < blocks; ++bi) {
          const long dim = lx.need_long("entity dimension");
          const long etag = lx.need_long("entity tag");
          const long type = lx.need_long("element type");
          const long n = lx.need_count("number of elements in block");
          check_type(type);
          std::vector<std::string> names;
          const auto it = entity_phys.find({static_cast<int>(dim), etag});
          if (it != entity_phys.end())
            for (long p : it->second) names.push_back(phys_name(static_cast<int>(dim), std::labs(p)));
          for (long i = 0; i < n; ++i) {
            const long id = lx.need_long("element tag");
            const int line = lx.line();
            for (int j = 0; j < gmsh_nodes(type); ++j) nodes[j] = lx.need_long("element node tag");
            add_elem(type, id, nodes, names, line, etag);
          }
        }
      }
    } else {  // $NodeData, $Periodic, ...: skipped
      const std::string end = "$End" + section;
      for (;;) {
        const std::string_view t = lx.need(end.c_str());
        if (t == end) break;
      }
      continue;
    }
    lx.expect(("$End" + section).c_str());
  }
  if (!have_nodes) fail(path, "no $Nodes section");
  if (!have_elements) fail(path, "no $Elements section");

  // Every named physical group gives a set, even an empty one (so empty sets survive write_msh).
  for (const auto& [key, name] : phys_names) {
    if (key.first <= 1) b.nset(name);
    else b.elset(name);
  }
  // Blocks: one per (type, first physical name), in order of first appearance.
  std::vector<std::pair<ElementType, std::string>> keys;
  std::vector<std::vector<std::size_t>> members;
  for (std::size_t i = 0; i < elems.size(); ++i) {
    const std::pair<ElementType, std::string> key{elems[i].type, elems[i].names.empty() ? std::string() : elems[i].names[0]};
    std::size_t k = std::find(keys.begin(), keys.end(), key) - keys.begin();
    if (k == keys.size()) {
      keys.push_back(key);
      members.emplace_back();
    }
    members[k].push_back(i);
  }
  for (std::size_t k = 0; k < keys.size(); ++k) {
    b.begin_block(keys[k].first, keys[k].second);
    for (std::size_t i : members[k]) {
      const Elem& e = elems[i];
      b.add_element(e.id, e.nodes.data(), e.loc);
      for (const auto& name : e.names) {
        auto& s = b.elset(name);
        s.ids.push_back(e.id);
        s.locs.push_back(e.loc);
      }
    }
  }
  return b.finish();
}

}  // namespace fe::femesh_detail
