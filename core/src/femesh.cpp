// Finite-element meshes: Abaqus/CalculiX .inp and gmsh .msh (2.x, 4.1 ASCII) input and output,
// element normals and quality. See featureextract/femesh.h.
#include "featureextract/femesh.h"

#include "featureextract/io.h"

#include "file_text.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <unordered_map>

namespace fe {

int nodes_per_element(ElementType type) {
  switch (type) {
    case ElementType::Tri3: return 3;
    case ElementType::Quad4: return 4;
    case ElementType::Tet4: return 4;
    case ElementType::Hex8: return 8;
  }
  return 0;
}

bool is_shell(ElementType type) { return type == ElementType::Tri3 || type == ElementType::Quad4; }

const char* inp_type_name(ElementType type) {
  switch (type) {
    case ElementType::Tri3: return "S3";
    case ElementType::Quad4: return "S4";
    case ElementType::Tet4: return "C3D4";
    case ElementType::Hex8: return "C3D8";
  }
  return "?";
}

std::size_t FeMesh::num_elements() const {
  std::size_t n = 0;
  for (const auto& b : blocks) n += static_cast<std::size_t>(b.conn.rows());
  return n;
}

namespace {

using Vec3 = Eigen::Vector3d;

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw InputError(path + ": " + what); }

std::string read_all(const std::string& path) { return read_file_text(path); }

std::string_view trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

std::string upper(std::string_view s) {
  std::string r(s);
  for (char& c : r) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return r;
}

// Printable, bounded excerpt of input text for messages (keeps them one line).
std::string excerpt(std::string_view s) {
  std::string r;
  for (char c : s.substr(0, 24)) r.push_back(std::isprint(static_cast<unsigned char>(c)) ? c : '?');
  if (s.size() > 24) r += "...";
  return r;
}

bool parse_long(std::string_view s, long& out) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  if (s.empty()) return false;
  const auto r = std::from_chars(s.data(), s.data() + s.size(), out);
  return r.ec == std::errc() && r.ptr == s.data() + s.size();
}

// Also accepts nan/inf (reported as non-finite by the caller) and Fortran 'D' exponents.
bool parse_double(std::string_view s, double& out) {
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

std::string file_dir(const std::string& path) {
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
// Abaqus / CalculiX .inp

bool map_inp_type(const std::string& t, ElementType& out) {
  static const std::unordered_map<std::string, ElementType> table = {
      {"S3", ElementType::Tri3},     {"S3R", ElementType::Tri3},     {"S3RS", ElementType::Tri3},   {"STRI3", ElementType::Tri3},
      {"M3D3", ElementType::Tri3},   {"R3D3", ElementType::Tri3},    {"DS3", ElementType::Tri3},    {"SFM3D3", ElementType::Tri3},
      {"CPS3", ElementType::Tri3},   {"CPE3", ElementType::Tri3},    {"CAX3", ElementType::Tri3},   {"S4", ElementType::Quad4},
      {"S4R", ElementType::Quad4},   {"S4R5", ElementType::Quad4},   {"S4RS", ElementType::Quad4},  {"M3D4", ElementType::Quad4},
      {"M3D4R", ElementType::Quad4}, {"R3D4", ElementType::Quad4},   {"DS4", ElementType::Quad4},   {"SFM3D4", ElementType::Quad4},
      {"SFM3D4R", ElementType::Quad4}, {"CPS4", ElementType::Quad4}, {"CPS4R", ElementType::Quad4}, {"CPE4", ElementType::Quad4},
      {"CPE4R", ElementType::Quad4}, {"CAX4", ElementType::Quad4},   {"CAX4R", ElementType::Quad4}, {"C3D4", ElementType::Tet4},
      {"C3D4H", ElementType::Tet4},  {"DC3D4", ElementType::Tet4},   {"C3D8", ElementType::Hex8},   {"C3D8R", ElementType::Hex8},
      {"C3D8I", ElementType::Hex8},  {"C3D8H", ElementType::Hex8},   {"C3D8RH", ElementType::Hex8}, {"C3D8IH", ElementType::Hex8},
      {"DC3D8", ElementType::Hex8}};
  const auto it = table.find(t);
  if (it == table.end()) return false;
  out = it->second;
  return true;
}

// Splits at commas outside double quotes; pieces are trimmed.
std::vector<std::string_view> split_commas(std::string_view s) {
  std::vector<std::string_view> out;
  bool quoted = false;
  std::size_t start = 0;
  for (std::size_t i = 0; i <= s.size(); ++i) {
    if (i < s.size() && s[i] == '"') quoted = !quoted;
    if (i == s.size() || (s[i] == ',' && !quoted)) {
      out.push_back(trim(s.substr(start, i - start)));
      start = i + 1;
    }
  }
  return out;
}

std::string unquote(std::string_view s) {
  s = trim(s);
  if (s.size() >= 2 && s.front() == '"' && s.back() == '"') s = s.substr(1, s.size() - 2);
  return std::string(s);
}

class InpReader {
 public:
  explicit InpReader(const std::string& path) { b_.path = path; }

  FeMesh read() {
    process(b_.path, 0);
    finish_record();
    return b_.finish();
  }

 private:
  enum class Mode { None, Skip, Node, Element, Nset, Elset };
  Builder b_;
  Mode mode_ = Mode::None;
  bool generate_ = false;
  bool any_keyword_ = false;
  std::string set_name_;
  std::string node_nset_;   // *NODE, NSET=
  std::string elem_elset_;  // *ELEMENT, ELSET=
  std::string elem_type_;
  std::vector<long> pending_;  // element record being assembled (continuation lines)
  Builder::Loc pending_loc_ = 0;

  void finish_record() {
    if (pending_.empty()) return;
    const int k = nodes_per_element(b_.blocks.back().type);
    b_.fail_at(pending_loc_, "incomplete " + elem_type_ + " element record (" + std::to_string(pending_.size() - 1) + " of " +
                                 std::to_string(k) + " node ids; truncated?)");
  }

  void process(const std::string& file, int depth) {
    if (depth > 16) fail(b_.path, "*INCLUDE nested too deeply (recursive?) at " + file);
    const std::string data = depth == 0 ? read_all(file) : read_included(file);
    const int file_index = static_cast<int>(b_.files.size());
    b_.files.push_back(file);
    if (depth == 0 && data.find('\0') != std::string::npos) fail(file, "not an Abaqus/CalculiX input file (binary data)");
    std::size_t pos = 0;
    int line_no = 0;
    while (pos < data.size()) {
      std::size_t end = data.find('\n', pos);
      if (end == std::string::npos) end = data.size();
      const std::string_view line = trim(std::string_view(data).substr(pos, end - pos));
      pos = end + 1;
      ++line_no;
      const Builder::Loc l = Builder::loc(file_index, line_no);
      if (line.empty() || (line.size() >= 2 && line[0] == '*' && line[1] == '*')) continue;
      if (line[0] == '*') {
        keyword(line, l, file, depth);
      } else {
        data_line(line, l);
      }
    }
  }

  std::string read_included(const std::string& file) {
    std::ifstream in(file, std::ios::binary);
    if (!in) fail(b_.path, "cannot open included file " + file);
    std::ostringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }

  void keyword(std::string_view line, Builder::Loc l, const std::string& file, int depth) {
    finish_record();
    any_keyword_ = true;
    const auto parts = split_commas(line.substr(1));
    std::string kw;
    for (char c : parts[0]) {  // upper case, runs of blanks collapsed ("*NODE  PRINT" -> "NODE PRINT")
      if (std::isspace(static_cast<unsigned char>(c))) {
        if (!kw.empty() && kw.back() != ' ') kw.push_back(' ');
      } else {
        kw.push_back(static_cast<char>(std::toupper(static_cast<unsigned char>(c))));
      }
    }
    std::map<std::string, std::string> params;
    for (std::size_t i = 1; i < parts.size(); ++i) {
      if (parts[i].empty()) continue;
      const auto eq = parts[i].find('=');
      if (eq == std::string_view::npos) params[upper(trim(parts[i]))] = "";
      else params[upper(trim(parts[i].substr(0, eq)))] = unquote(parts[i].substr(eq + 1));
    }
    auto param = [&](const char* key) -> std::string {
      const auto it = params.find(key);
      return it == params.end() ? std::string() : it->second;
    };
    generate_ = params.count("GENERATE") > 0;
    if (kw == "INCLUDE") {
      const std::string input = param("INPUT");
      if (input.empty()) b_.fail_at(l, "*INCLUDE without INPUT=");
      process(input.front() == '/' ? input : file_dir(file) + input, depth + 1);
      return;  // the included data continue the current keyword, as in Abaqus
    }
    if (kw == "NODE") {
      const std::string system = upper(param("SYSTEM"));
      if (!system.empty() && system != "R") b_.fail_at(l, "*NODE, SYSTEM=" + system + " is not supported (only rectangular coordinates)");
      mode_ = Mode::Node;
      node_nset_ = param("NSET");
      if (!node_nset_.empty()) b_.nset(node_nset_);
    } else if (kw == "ELEMENT") {
      elem_type_ = upper(param("TYPE"));
      if (elem_type_.empty()) b_.fail_at(l, "*ELEMENT without TYPE=");
      ElementType t;
      if (!map_inp_type(elem_type_, t))
        b_.fail_at(l, "unsupported element type " + excerpt(elem_type_) + " (supported: linear shells S3/S4 and solids C3D4/C3D8 and their variants)");
      mode_ = Mode::Element;
      elem_elset_ = param("ELSET");
      b_.begin_block(t, elem_elset_);
      if (!elem_elset_.empty()) b_.elset(elem_elset_);
    } else if (kw == "NSET" || kw == "ELSET") {
      const bool nodes = kw == "NSET";
      set_name_ = param(nodes ? "NSET" : "ELSET");
      if (set_name_.empty()) b_.fail_at(l, "*" + kw + " without " + kw + "=");
      mode_ = nodes ? Mode::Nset : Mode::Elset;
      if (nodes) b_.nset(set_name_);
      else b_.elset(set_name_);
    } else {
      mode_ = Mode::Skip;
      return;
    }
    const std::string input = param("INPUT");  // data lines in a separate file
    if (!input.empty()) process(input.front() == '/' ? input : file_dir(file) + input, depth + 1);
  }

  void data_line(std::string_view line, Builder::Loc l) {
    switch (mode_) {
      case Mode::None:
        if (!any_keyword_) b_.fail_at(l, "not an Abaqus/CalculiX input file (expected a *KEYWORD line, found '" + excerpt(line) + "')");
        return;
      case Mode::Skip: return;
      case Mode::Node: return node_line(line, l);
      case Mode::Element: return element_line(line, l);
      case Mode::Nset:
      case Mode::Elset: return set_line(line, l);
    }
  }

  void node_line(std::string_view line, Builder::Loc l) {
    const auto f = split_commas(line);
    long id;
    double c[3] = {0, 0, 0};
    if (f.size() < 2 || !parse_long(f[0], id)) b_.fail_at(l, "malformed *NODE line '" + excerpt(line) + "' (expected id, x, y, z)");
    for (std::size_t i = 1; i < f.size() && i <= 3; ++i) {
      if (f[i].empty()) continue;
      if (!parse_double(f[i], c[i - 1])) b_.fail_at(l, "malformed coordinate '" + excerpt(f[i]) + "' of node " + std::to_string(id));
    }
    b_.add_node(id, c[0], c[1], c[2], l);
    if (!node_nset_.empty()) {
      auto& s = b_.nset(node_nset_);
      s.ids.push_back(id);
      s.locs.push_back(l);
    }
  }

  void element_line(std::string_view line, Builder::Loc l) {
    const int k = nodes_per_element(b_.blocks.back().type);
    if (pending_.empty()) pending_loc_ = l;
    for (const auto& f : split_commas(line)) {
      if (f.empty()) continue;  // trailing comma = continuation mark
      long v;
      if (!parse_long(f, v)) b_.fail_at(l, "malformed *ELEMENT value '" + excerpt(f) + "' (expected integer ids)");
      pending_.push_back(v);
    }
    if (pending_.size() > static_cast<std::size_t>(k + 1))
      b_.fail_at(pending_loc_, "element " + std::to_string(pending_[0]) + " has " + std::to_string(pending_.size() - 1) + " node ids, " + elem_type_ +
                                   " needs " + std::to_string(k));
    if (pending_.size() == static_cast<std::size_t>(k + 1)) {
      b_.add_element(pending_[0], pending_.data() + 1, pending_loc_);
      if (!elem_elset_.empty()) {
        auto& s = b_.elset(elem_elset_);
        s.ids.push_back(pending_[0]);
        s.locs.push_back(pending_loc_);
      }
      pending_.clear();
    }
  }

  void set_line(std::string_view line, Builder::Loc l) {
    const bool nodes = mode_ == Mode::Nset;
    Builder::RawSet& s = nodes ? b_.nset(set_name_) : b_.elset(set_name_);
    std::vector<std::string_view> f = split_commas(line);
    while (!f.empty() && f.back().empty()) f.pop_back();
    if (generate_) {
      long v[3] = {0, 0, 1};
      if (f.size() < 2 || f.size() > 3) b_.fail_at(l, "GENERATE line needs first, last[, increment], found '" + excerpt(line) + "'");
      for (std::size_t i = 0; i < f.size(); ++i)
        if (!parse_long(f[i], v[i])) b_.fail_at(l, "malformed GENERATE value '" + excerpt(f[i]) + "'");
      if (v[2] <= 0 || v[1] < v[0] || (v[1] - v[0]) / v[2] > 100000000L)
        b_.fail_at(l, "bad GENERATE range " + std::to_string(v[0]) + ", " + std::to_string(v[1]) + ", " + std::to_string(v[2]));
      for (long id = v[0]; id <= v[1]; id += v[2]) {
        s.ids.push_back(id);
        s.locs.push_back(l);
      }
      return;
    }
    for (const auto& t : f) {
      if (t.empty()) continue;
      long id;
      if (parse_long(t, id)) {
        s.ids.push_back(id);
        s.locs.push_back(l);
        continue;
      }
      const std::string name = unquote(t);
      const Builder::RawSet* other = nodes ? Builder::find(b_.nsets, b_.nset_index, name) : Builder::find(b_.elsets, b_.elset_index, name);
      if (!other) b_.fail_at(l, std::string(nodes ? "node" : "element") + " set " + set_name_ + " refers to unknown set or bad id '" + excerpt(t) + "'");
      if (other == &s) continue;
      const std::vector<long> ids = other->ids;  // copy: s and other live in the same vector
      const std::vector<Builder::Loc> locs = other->locs;
      Builder::RawSet& s2 = nodes ? b_.nset(set_name_) : b_.elset(set_name_);
      s2.ids.insert(s2.ids.end(), ids.begin(), ids.end());
      s2.locs.insert(s2.locs.end(), locs.begin(), locs.end());
    }
  }
};

// ------------------------------------------------------------------------------------------------
// gmsh .msh, ASCII 2.x and 4.1

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
    std::array<long, 8> nodes;
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
    const ElementType t = type == 2 ? ElementType::Tri3 : type == 3 ? ElementType::Quad4 : type == 4 ? ElementType::Tet4 : ElementType::Hex8;
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
               "; supported: 2 (triangle), 3 (quadrangle), 4 (tetrahedron), 5 (hexahedron), points and lines for node sets");
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
      long nodes[8];
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

// ------------------------------------------------------------------------------------------------
// Writing

void check_mesh(const FeMesh& m) {
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

long node_id(const FeMesh& m, int i) { return m.node_ids.empty() ? i + 1 : m.node_ids[static_cast<std::size_t>(i)]; }

// External id of every element, global order.
std::vector<long> element_ids(const FeMesh& m) {
  std::vector<long> ids;
  for (const auto& b : m.blocks)
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r)
      ids.push_back(b.ids.empty() ? static_cast<long>(ids.size()) + 1 : b.ids[static_cast<std::size_t>(r)]);
  return ids;
}

// element_sets plus the blocks' elsets.
std::map<std::string, std::vector<int>> all_element_sets(const FeMesh& m) {
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

std::string inp_name(const std::string& name) {
  const bool plain = !name.empty() && std::all_of(name.begin(), name.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.';
  });
  return plain ? name : "\"" + name + "\"";
}

void write_id_list(File& out, const std::vector<long>& ids) {
  for (std::size_t i = 0; i < ids.size(); ++i) {
    out.num(ids[i]);
    out.put((i + 1) % 16 == 0 || i + 1 == ids.size() ? "\n" : ", ");
  }
}

}  // namespace

FeMesh read_fe_mesh(const std::string& path) {
  const std::string ext = file_extension(path);
  if (ext == "inp") return InpReader(path).read();
  if (ext == "msh") return read_msh(path);
  fail(path, "unknown FE mesh file type '." + ext + "' (supported: .inp, .msh)");
}

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
    std::vector<std::vector<std::size_t>> by_type{4};  // global element indices per ElementType
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
  static const int gmsh_type[4] = {2, 3, 4, 5};
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
      for (int t = 0; t < 4; ++t) {
        const auto& v = e.by_type[static_cast<std::size_t>(t)];
        if (v.empty()) continue;
        out.put(std::to_string(e.dim) + " " + std::to_string(e.tag) + " " + std::to_string(gmsh_type[t]) + " " + std::to_string(v.size()) + "\n");
        for (std::size_t g : v) {
          const auto& b = m.blocks[static_cast<std::size_t>(refs[g].block)];
          out.num(eids[g]);
          for (Eigen::Index j = 0; j < b.conn.cols(); ++j) {
            out.put(" ");
            out.num(node_id(m, b.conn(refs[g].row, j)));
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

// ------------------------------------------------------------------------------------------------
// Quality

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kRadToDeg = 57.29577951308232;

double angle_deg(const Vec3& u, const Vec3& v) {
  if (u.squaredNorm() == 0 || v.squaredNorm() == 0) return 0;
  return std::atan2(u.cross(v).norm(), u.dot(v)) * kRadToDeg;
}

double tri_min_angle(const Vec3& a, const Vec3& b, const Vec3& c) {
  return std::min({angle_deg(b - a, c - a), angle_deg(c - b, a - b), angle_deg(a - c, b - c)});
}

// Corner of a quad face: unsigned angle, or 360 - angle at a reflex corner (measured along n).
double quad_min_angle(const std::array<Vec3, 4>& x, const Vec3& n) {
  double lo = kInf;
  for (int i = 0; i < 4; ++i) {
    const Vec3 e1 = x[(i + 1) % 4] - x[i], e2 = x[(i + 3) % 4] - x[i];
    double a = angle_deg(e1, e2);
    if (n.squaredNorm() > 0 && e1.cross(e2).dot(n) < 0) a = 360 - a;
    lo = std::min(lo, a);
  }
  return lo;
}

double safe_ratio(double num, double den) { return den > 0 ? num / den : (num == 0 ? 0 : (num > 0 ? kInf : -kInf)); }

ElementQuality tri_quality(const std::array<Vec3, 4>& x, const Vec3& ref) {
  ElementQuality q;
  const Vec3 &a = x[0], &b = x[1], &c = x[2];
  const double l0 = (b - a).norm(), l1 = (c - b).norm(), l2 = (a - c).norm();
  const Vec3 n = (b - a).cross(c - a);
  const double area2 = n.norm();
  const double lmax = std::max({l0, l1, l2});
  q.aspect_ratio = area2 > 0 ? lmax * lmax * std::sqrt(3.0) / (2 * area2) : kInf;
  const Vec3 dir = ref.squaredNorm() > 0 ? Vec3(ref.normalized()) : (area2 > 0 ? Vec3(n / area2) : Vec3::Zero());
  // The corner Jacobian is the same at all three corners; as in Verdict it is scaled by the largest
  // product of corner edge lengths (= the minimum over corners for s >= 0, and sign-symmetric).
  const double s = n.dot(dir);
  q.scaled_jacobian = 2 / std::sqrt(3.0) * safe_ratio(s, std::max({l0 * l2, l0 * l1, l1 * l2}));
  q.min_angle_deg = tri_min_angle(a, b, c);
  q.inverted = q.scaled_jacobian < 0;
  return q;
}

ElementQuality quad_quality(const std::array<Vec3, 4>& x, const Vec3& ref) {
  ElementQuality q;
  const Vec3 n = (x[2] - x[0]).cross(x[3] - x[1]);
  const Vec3 dir = ref.squaredNorm() > 0 ? Vec3(ref.normalized()) : (n.squaredNorm() > 0 ? Vec3(n.normalized()) : Vec3::Zero());
  double lmin = kInf, lmax = 0, sj = kInf;
  for (int i = 0; i < 4; ++i) {
    const Vec3 e1 = x[(i + 1) % 4] - x[i], e2 = x[(i + 3) % 4] - x[i];
    lmin = std::min(lmin, e1.norm());
    lmax = std::max(lmax, e1.norm());
    sj = std::min(sj, safe_ratio(e1.cross(e2).dot(dir), e1.norm() * e2.norm()));
  }
  q.aspect_ratio = lmin > 0 ? lmax / lmin : kInf;
  q.scaled_jacobian = sj;
  q.min_angle_deg = quad_min_angle(x, dir);
  q.inverted = sj < 0;
  return q;
}

double corner(const Vec3& origin, const Vec3& p, const Vec3& q, const Vec3& r) {
  const Vec3 a = p - origin, b = q - origin, c = r - origin;
  return safe_ratio(a.cross(b).dot(c), a.norm() * b.norm() * c.norm());
}

ElementQuality tet_quality(const std::array<Vec3, 8>& x) {
  ElementQuality q;
  // As for triangles (and in Verdict): the corner determinant, equal at all corners, over the largest
  // product of corner edge lengths.
  const double det = (x[1] - x[0]).cross(x[2] - x[0]).dot(x[3] - x[0]);
  std::array<double, 6> l;  // edges 01 02 03 12 13 23
  l = {(x[1] - x[0]).norm(), (x[2] - x[0]).norm(), (x[3] - x[0]).norm(), (x[2] - x[1]).norm(), (x[3] - x[1]).norm(), (x[3] - x[2]).norm()};
  const double pmax = std::max({l[0] * l[1] * l[2], l[0] * l[3] * l[4], l[1] * l[3] * l[5], l[2] * l[4] * l[5]});
  q.scaled_jacobian = std::sqrt(2.0) * safe_ratio(det, pmax);
  q.inverted = det < 0;
  const double volume = std::abs(det) / 6;
  static const int faces[4][3] = {{0, 1, 2}, {0, 1, 3}, {1, 2, 3}, {0, 2, 3}};
  double area = 0, lmax = 0, amin = kInf;
  for (const auto& f : faces) {
    area += (x[f[1]] - x[f[0]]).cross(x[f[2]] - x[f[0]]).norm() / 2;
    amin = std::min(amin, tri_min_angle(x[f[0]], x[f[1]], x[f[2]]));
  }
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j) lmax = std::max(lmax, (x[i] - x[j]).norm());
  const double inradius = area > 0 ? 3 * volume / area : 0;
  q.aspect_ratio = inradius > 0 ? lmax / (2 * std::sqrt(6.0) * inradius) : kInf;
  q.min_angle_deg = amin;
  return q;
}

ElementQuality hex_quality(const std::array<Vec3, 8>& x) {
  ElementQuality q;
  double sj = kInf;
  for (int k = 0; k < 4; ++k) {
    sj = std::min(sj, corner(x[k], x[(k + 1) % 4], x[(k + 3) % 4], x[k + 4]));
    sj = std::min(sj, corner(x[4 + k], x[4 + (k + 3) % 4], x[4 + (k + 1) % 4], x[k]));
  }
  q.scaled_jacobian = sj;
  q.inverted = sj < 0;
  double lmin = kInf, lmax = 0;
  for (int k = 0; k < 4; ++k)
    for (const auto& e : {std::make_pair(k, (k + 1) % 4), std::make_pair(4 + k, 4 + (k + 1) % 4), std::make_pair(k, k + 4)}) {
      const double l = (x[e.first] - x[e.second]).norm();
      lmin = std::min(lmin, l);
      lmax = std::max(lmax, l);
    }
  q.aspect_ratio = lmin > 0 ? lmax / lmin : kInf;
  static const int faces[6][4] = {{0, 1, 2, 3}, {4, 5, 6, 7}, {0, 1, 5, 4}, {1, 2, 6, 5}, {2, 3, 7, 6}, {3, 0, 4, 7}};
  double amin = kInf;
  for (const auto& f : faces) amin = std::min(amin, quad_min_angle({x[f[0]], x[f[1]], x[f[2]], x[f[3]]}, Vec3::Zero()));
  q.min_angle_deg = amin;
  return q;
}

}  // namespace

std::vector<ElementQuality> element_quality(const FeMesh& m, const Points* reference_normals) {
  const std::size_t ne = m.num_elements();
  if (reference_normals && static_cast<std::size_t>(reference_normals->rows()) != ne)
    throw std::invalid_argument("element_quality: " + std::to_string(reference_normals->rows()) + " reference normals for " + std::to_string(ne) + " elements");
  std::vector<ElementQuality> out;
  out.reserve(ne);
  for (const auto& b : m.blocks) {
    const int k = nodes_per_element(b.type);
    if (b.conn.rows() > 0 && b.conn.cols() != k) throw std::invalid_argument("element_quality: block with wrong number of columns");
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r) {
      std::array<Vec3, 8> x;
      for (int j = 0; j < k; ++j) {
        const int i = b.conn(r, j);
        if (i < 0 || i >= m.nodes.rows()) throw std::invalid_argument("element_quality: node index out of range");
        x[static_cast<std::size_t>(j)] = m.nodes.row(i).transpose();
      }
      const Vec3 ref = reference_normals ? Vec3(reference_normals->row(static_cast<Eigen::Index>(out.size())).transpose()) : Vec3::Zero();
      switch (b.type) {
        case ElementType::Tri3: out.push_back(tri_quality({x[0], x[1], x[2], x[2]}, ref)); break;
        case ElementType::Quad4: out.push_back(quad_quality({x[0], x[1], x[2], x[3]}, ref)); break;
        case ElementType::Tet4: out.push_back(tet_quality(x)); break;
        case ElementType::Hex8: out.push_back(hex_quality(x)); break;
      }
    }
  }
  return out;
}

Points element_normals(const FeMesh& m) {
  Points n = Points::Zero(static_cast<Eigen::Index>(m.num_elements()), 3);
  Eigen::Index g = 0;
  for (const auto& b : m.blocks) {
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r, ++g) {
      if (!is_shell(b.type)) continue;
      auto p = [&](int j) -> Vec3 { return m.nodes.row(b.conn(r, j)).transpose(); };
      const Vec3 v = b.type == ElementType::Tri3 ? Vec3((p(1) - p(0)).cross(p(2) - p(0))) : Vec3((p(2) - p(0)).cross(p(3) - p(1)));
      const double len = v.norm();
      if (len > 0) n.row(g) = (v / len).transpose();
    }
  }
  return n;
}

QualitySummary summarize(const std::vector<ElementQuality>& q) {
  QualitySummary s;
  s.elements = q.size();
  if (q.empty()) return s;
  std::vector<double> sj, ar;
  double angle = kInf;
  for (const auto& e : q) {
    s.inverted += e.inverted;
    sj.push_back(e.scaled_jacobian);
    ar.push_back(e.aspect_ratio);
    angle = std::min(angle, e.min_angle_deg);
  }
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const std::size_t h = v.size() / 2;
    return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
  };
  s.min_scaled_jacobian = *std::min_element(sj.begin(), sj.end());
  s.max_aspect_ratio = *std::max_element(ar.begin(), ar.end());
  s.median_scaled_jacobian = median(sj);
  s.median_aspect_ratio = median(ar);
  s.min_angle_deg = angle;
  return s;
}

}  // namespace fe
