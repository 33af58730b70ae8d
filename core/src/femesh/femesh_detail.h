// Internal to the FE-mesh library (featureextract/femesh.h): the text helpers, the builder the
// readers fill, and the writers' helpers, shared by the format files (inp_read, msh_read, inp_write,
// msh_write). Eigen and std only.
#pragma once

#include "featureextract/femesh.h"

#include "../file_text.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <stdexcept>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace fe::femesh_detail {

using Vec3 = Eigen::Vector3d;

[[noreturn]] inline void fail(const std::string& path, const std::string& what) { throw InputError(path + ": " + what); }

inline std::string read_all(const std::string& path) { return read_file_text(path); }

inline std::string_view trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

inline std::string upper(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return r;
}

// Printable, bounded excerpt of input text for messages (keeps them one line).
inline std::string excerpt(std::string_view s) {
  std::string r;
  for (char c : s.substr(0, 24)) r.push_back(std::isprint(static_cast<unsigned char>(c)) ? c : '?');
  if (s.size() > 24) r += "...";
  return r;
}

inline bool parse_long(std::string_view s, long& out) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// Also accepts nan/inf (reported as non-finite by the caller) and Fortran 'D' exponents.
inline bool parse_double(std::string_view s, double& out) {
  s = trim(s);
  if (s.empty() || s.size() > 64) return false;
  char buf[72];
  std::size_t n = 0;
  for (char c : s) buf[n++] = (c == 'd' || c == 'D') ? 'e' : c;
  buf[n] = '\0';
  char* end = nullptr;
  out = std::strtod(buf, &end);
  return end == buf + n;
}

inline std::string file_dir(const std::string& path) {
  const auto slash = path.find_last_of("/\\");
  return slash == std::string::npos ? std::string() : path.substr(0, slash + 1);
}

// ------------------------------------------------------------------------------------------------
// Collects nodes, elements and sets by external id while a file is read; resolves them at the end.

struct Builder {
  std::string path;
  std::vector<std::string> files;  // files[0] == path; included files follow

  using Loc = long long;  // (file index << 32) | line
  static Loc loc(int file, int line) { return (static_cast<Loc>(file) << 32) | static_cast<unsigned>(line); }
  std::string where(Loc l) const {
    const int file = static_cast<int>(l >> 32), line = static_cast<int>(l & 0xffffffff);
    return (file == 0 ? std::string() : files[static_cast<std::size_t>(file)] + " ") + "line " + std::to_string(line);
  }
  [[noreturn]] void fail_at(Loc l, const std::string& what) const { fail(path, where(l) + ": " + what); }

  std::vector<long> node_ids;
  std::vector<double> xyz;
  std::unordered_map<long, int> node_index;

  struct RawBlock {
    ElementType type;
    std::string elset;
    std::vector<long> ids, nodes;  // external ids
    std::vector<Loc> locs;
  };
  std::vector<RawBlock> blocks;
  std::unordered_map<long, Loc> element_seen;

  struct RawSet {
    std::string name;
    std::vector<long> ids;
    std::vector<Loc> locs;
  };
  std::vector<RawSet> nsets, elsets;
  std::unordered_map<std::string, int> nset_index, elset_index;  // upper-case name -> position

  void add_node(long id, double x, double y, double z, Loc l) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) fail_at(l, "node " + std::to_string(id) + " has non-finite coordinates");
    if (!node_index.emplace(id, static_cast<int>(node_ids.size())).second) fail_at(l, "duplicate node id " + std::to_string(id));
    node_ids.push_back(id);
    xyz.insert(xyz.end(), {x, y, z});
  }
  void begin_block(ElementType type, const std::string& elset) { blocks.push_back({type, elset, {}, {}, {}}); }
  void add_element(long id, const long* nodes, Loc l) {
    RawBlock& b = blocks.back();
    if (!element_seen.emplace(id, l).second) fail_at(l, "duplicate element id " + std::to_string(id));
    b.ids.push_back(id);
    b.nodes.insert(b.nodes.end(), nodes, nodes + nodes_per_element(b.type));
    b.locs.push_back(l);
  }
  static RawSet& set(std::vector<RawSet>& sets, std::unordered_map<std::string, int>& index, const std::string& name) {
    const auto it = index.emplace(upper(name), static_cast<int>(sets.size()));
    if (it.second) sets.push_back({name, {}, {}});
    return sets[static_cast<std::size_t>(it.first->second)];
  }
  static const RawSet* find(const std::vector<RawSet>& sets, const std::unordered_map<std::string, int>& index, std::string_view name) {
    const auto it = index.find(upper(name));
    return it == index.end() ? nullptr : &sets[static_cast<std::size_t>(it->second)];
  }
  RawSet& nset(const std::string& name) { return set(nsets, nset_index, name); }
  RawSet& elset(const std::string& name) { return set(elsets, elset_index, name); }

  FeMesh finish() {
    FeMesh m;
    if (node_ids.empty()) fail(path, "no nodes found");
    m.node_ids = std::move(node_ids);
    m.nodes = Eigen::Map<Points>(xyz.data(), static_cast<Eigen::Index>(m.node_ids.size()), 3);
    std::unordered_map<long, int> element_index;
    int global = 0;
    for (RawBlock& rb : blocks) {
      if (rb.ids.empty()) continue;
      const int k = nodes_per_element(rb.type);
      ElementBlock b;
      b.type = rb.type;
      b.elset = rb.elset;
      b.conn.resize(static_cast<Eigen::Index>(rb.ids.size()), k);
      for (std::size_t e = 0; e < rb.ids.size(); ++e) {
        for (int j = 0; j < k; ++j) {
          const long id = rb.nodes[e * k + j];
          const auto it = node_index.find(id);
          if (it == node_index.end()) fail_at(rb.locs[e], "element " + std::to_string(rb.ids[e]) + " refers to missing node " + std::to_string(id));
          b.conn(static_cast<Eigen::Index>(e), j) = it->second;
        }
        element_index.emplace(rb.ids[e], global++);
      }
      b.ids = std::move(rb.ids);
      m.blocks.push_back(std::move(b));
    }
    auto resolve = [&](const std::vector<RawSet>& sets, const std::unordered_map<long, int>& index, const char* what,
                       std::map<std::string, std::vector<int>>& out) {
      for (const RawSet& s : sets) {
        std::vector<int> v;
        v.reserve(s.ids.size());
        for (std::size_t i = 0; i < s.ids.size(); ++i) {
          const auto it = index.find(s.ids[i]);
          if (it == index.end()) fail_at(s.locs[i], std::string(what) + " set " + s.name + " refers to missing " + what + " " + std::to_string(s.ids[i]));
          v.push_back(it->second);
        }
        std::sort(v.begin(), v.end());
        v.erase(std::unique(v.begin(), v.end()), v.end());
        out[s.name] = std::move(v);
      }
    };
    resolve(nsets, node_index, "node", m.node_sets);
    resolve(elsets, element_index, "element", m.element_sets);
    return m;
  }
};

// ------------------------------------------------------------------------------------------------
// Writing

inline void check_mesh(const FeMesh& m) {
  const Eigen::Index n = m.nodes.rows();
  if (!m.node_ids.empty() && static_cast<Eigen::Index>(m.node_ids.size()) != n)
    throw std::invalid_argument("FeMesh: node_ids has " + std::to_string(m.node_ids.size()) + " entries for " + std::to_string(n) + " nodes");
  for (long id : m.node_ids)
    if (id <= 0) throw std::invalid_argument("FeMesh: node id " + std::to_string(id) + " is not positive");
  for (const auto& b : m.blocks) {
    if (b.conn.cols() != nodes_per_element(b.type) && b.conn.rows() > 0)
      throw std::invalid_argument(std::string("FeMesh: ") + inp_type_name(b.type) + " block has " + std::to_string(b.conn.cols()) + " columns");
    if (!b.ids.empty() && static_cast<Eigen::Index>(b.ids.size()) != b.conn.rows())
      throw std::invalid_argument("FeMesh: block ids and conn rows differ");
    for (long id : b.ids)
      if (id <= 0) throw std::invalid_argument("FeMesh: element id " + std::to_string(id) + " is not positive");
    if (b.conn.size() > 0 && (b.conn.minCoeff() < 0 || b.conn.maxCoeff() >= n))
      throw std::invalid_argument("FeMesh: connectivity refers to a node index out of range");
  }
  const long ne = static_cast<long>(m.num_elements());
  for (const auto& [name, v] : m.node_sets)
    for (int i : v)
      if (i < 0 || i >= n) throw std::invalid_argument("FeMesh: node set " + name + " has index out of range");
  for (const auto& [name, v] : m.element_sets)
    for (int i : v)
      if (i < 0 || i >= ne) throw std::invalid_argument("FeMesh: element set " + name + " has index out of range");
}

inline long node_id(const FeMesh& m, int i) { return m.node_ids.empty() ? i + 1 : m.node_ids[static_cast<std::size_t>(i)]; }

// External id of every element, global order.
inline std::vector<long> element_ids(const FeMesh& m) {
  std::vector<long> ids;
  for (const auto& b : m.blocks)
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r)
      ids.push_back(b.ids.empty() ? static_cast<long>(ids.size()) + 1 : b.ids[static_cast<std::size_t>(r)]);
  return ids;
}

// element_sets plus the blocks' elsets.
inline std::map<std::string, std::vector<int>> all_element_sets(const FeMesh& m) {
  std::map<std::string, std::vector<int>> sets = m.element_sets;
  int g = 0;
  for (const auto& b : m.blocks) {
    if (!b.elset.empty()) {
      auto& s = sets[b.elset];
      for (Eigen::Index r = 0; r < b.conn.rows(); ++r) s.push_back(g + static_cast<int>(r));
    }
    g += static_cast<int>(b.conn.rows());
  }
  for (auto& [name, v] : sets) {
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
  }
  return sets;
}

struct File {
  std::FILE* f;
  std::string path;
  explicit File(const std::string& p) : f(std::fopen(p.c_str(), "wb")), path(p) {
    if (!f) throw std::runtime_error(p + ": cannot write");
  }
  ~File() {
    if (f) std::fclose(f);
  }
  void close() {
    const bool bad = std::ferror(f) != 0;
    const bool bad_close = std::fclose(f) != 0;
    f = nullptr;
    if (bad || bad_close) throw std::runtime_error(path + ": write failed");
  }
  void put(const std::string& s) { std::fwrite(s.data(), 1, s.size(), f); }
  void put(const char* s) { std::fputs(s, f); }
  void num(long v) { std::fprintf(f, "%ld", v); }
  void num(double v) {  // shortest text that reads back exactly, if it fits CalculiX's 20 characters
    char buf[64];
    auto r = std::to_chars(buf, buf + sizeof(buf), v);
    if (r.ptr - buf > 20) r = std::to_chars(buf, buf + sizeof(buf), v, std::chars_format::general, 13);
    std::fwrite(buf, 1, static_cast<std::size_t>(r.ptr - buf), f);
  }
};

inline std::string inp_name(const std::string& name) {
  const bool plain = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
  return plain ? name : "\"" + name + "\"";
}

inline void write_id_list(File& out, const std::vector<long>& ids) {
  for (std::size_t i = 0; i < ids.size(); ++i) {
    out.num(ids[i]);
    out.put((i + 1) % 16 == 0 || i + 1 == ids.size() ? "\n" : ", ");
  }
}

/// Abaqus/CalculiX .inp (inp_read.cpp) and gmsh .msh 2.x / 4.1 ASCII (msh_read.cpp).
FeMesh read_inp(const std::string& path);
FeMesh read_msh(const std::string& path);

}  // namespace fe::femesh_detail
