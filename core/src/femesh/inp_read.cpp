// Reading Abaqus / CalculiX .inp (see read_fe_mesh in featureextract/femesh.h).
#include "femesh_detail.h"

namespace fe::femesh_detail {

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
      {"DC3D8", ElementType::Hex8},  {"C3D10", ElementType::Tet10},  {"C3D10M", ElementType::Tet10}, {"C3D10H", ElementType::Tet10},
      {"C3D10I", ElementType::Tet10}, {"DC3D10", ElementType::Tet10}};
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
        b_.fail_at(l, "unsupported element type " + excerpt(elem_type_) + " (supported: linear shells S3/S4 and solids C3D4/C3D8/C3D10 and their variants)");
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

FeMesh read_inp(const std::string& path) { return InpReader(path).read(); }

}  // namespace fe::femesh_detail
