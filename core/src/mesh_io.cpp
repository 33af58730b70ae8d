// Triangle-mesh input (STL ascii/binary, OBJ, PLY) and validation. B-rep input is in brep_io.cpp.
#include "featureextract/io.h"

#include "file_text.h"

#include <Eigen/Geometry>  // .cross()
#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <unordered_map>

namespace fe {

double TriangleMesh::diagonal() const {
  if (vertices.rows() == 0) return 0.0;
  return (vertices.colwise().maxCoeff() - vertices.colwise().minCoeff()).norm();
}

std::string file_extension(const std::string& path) {
  const auto slash = path.find_last_of("/\\");
  const auto dot = path.find_last_of('.');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return "";
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw InputError(path + ": " + what);
}

std::string read_all(const std::string& path) { return read_file_text(path); }

struct Builder {
  std::vector<double> v;
  std::vector<int> t;
  void vertex(double x, double y, double z) {
    v.push_back(x);
    v.push_back(y);
    v.push_back(z);
  }
  // A polygon is cut into a fan from its first vertex. That is right only for a planar convex polygon:
  // there the fan's triangles add up to the polygon's vector area. Otherwise the fan covers surface
  // the model does not have (a face listing vertices from all over the mesh): refused, from 5 corners
  // on (quads are fanned as they come).
  void polygon(const std::vector<int>& idx, const std::string& path, const std::string& where) {
    if (idx.size() > 4) {
      auto p = [&](int i) { return Eigen::Vector3d(v[3 * static_cast<std::size_t>(i)], v[3 * static_cast<std::size_t>(i) + 1], v[3 * static_cast<std::size_t>(i) + 2]); };
      Eigen::Vector3d vec = Eigen::Vector3d::Zero();
      double sum = 0;
      for (std::size_t k = 1; k + 1 < idx.size(); ++k) {
        const Eigen::Vector3d c = (p(idx[k]) - p(idx[0])).cross(p(idx[k + 1]) - p(idx[0]));
        vec += c;
        sum += c.norm();
      }
      if (!(vec.norm() >= 0.98 * sum))
        fail(path, where + ": a " + std::to_string(idx.size()) + "-vertex face that is not planar and convex; triangulate it when exporting");
    }
    for (std::size_t k = 1; k + 1 < idx.size(); ++k) tri(idx[0], idx[k], idx[k + 1]);
  }
  void tri(int a, int b, int c) {
    t.push_back(a);
    t.push_back(b);
    t.push_back(c);
  }
  TriangleMesh finish(const std::string& source) {
    TriangleMesh m;
    m.source = source;
    m.vertices = Eigen::Map<Points>(v.data(), static_cast<Eigen::Index>(v.size() / 3), 3);
    m.triangles = Eigen::Map<Triangles>(t.data(), static_cast<Eigen::Index>(t.size() / 3), 3);
    m.face_ids = Eigen::VectorXi::Zero(m.triangles.rows());
    return m;
  }
};

// Like `in >> x` but also accepts "nan"/"inf" (so they are reported as non-finite, not malformed).
bool read_double(std::istream& in, double& x) {
  std::string w;
  if (!(in >> w)) return false;
  char* end = nullptr;
  x = std::strtod(w.c_str(), &end);
  return end != w.c_str() && *end == '\0';
}

bool looks_binary_stl(const std::string& d) {
  if (d.size() < 84) return false;
  std::uint32_t n;
  std::memcpy(&n, d.data() + 80, 4);
  return d.size() == 84 + 50ull * n;
}

TriangleMesh read_stl(const std::string& path) {
  const std::string d = read_all(path);
  Builder b;
  if (looks_binary_stl(d)) {
    std::uint32_t n;
    std::memcpy(&n, d.data() + 80, 4);
    for (std::uint32_t i = 0; i < n; ++i) {
      const char* rec = d.data() + 84 + 50ull * i + 12;  // skip the stored normal
      float c[9];
      std::memcpy(c, rec, sizeof(c));
      for (int k = 0; k < 3; ++k) b.vertex(c[3 * k], c[3 * k + 1], c[3 * k + 2]);
      b.tri(3 * i, 3 * i + 1, 3 * i + 2);
    }
    return b.finish(path);
  }
  // ascii: "solid ... facet normal ... outer loop vertex x y z x3 endloop endfacet ... endsolid"
  std::size_t start = d.find_first_not_of(" \t\r\n");
  if (start == std::string::npos || d.compare(start, 5, "solid") != 0) {
    if (d.size() >= 84) fail(path, "not an STL file: binary size does not match its triangle count (truncated?) and no ascii 'solid' header");
    fail(path, "not an STL file (too short for binary STL, no ascii 'solid' header)");
  }
  std::istringstream in(d);
  std::string tok;
  int in_loop = 0;
  std::size_t line_vertices = 0;
  while (in >> tok) {
    if (tok == "vertex") {
      double x, y, z;
      if (!(read_double(in, x) && read_double(in, y) && read_double(in, z))) fail(path, "malformed 'vertex' line in ascii STL (facet " + std::to_string(b.t.size() / 3 + 1) + ")");
      b.vertex(x, y, z);
      ++in_loop;
      ++line_vertices;
    } else if (tok == "endloop") {
      if (in_loop != 3) fail(path, "ascii STL facet " + std::to_string(b.t.size() / 3 + 1) + " has " + std::to_string(in_loop) + " vertices, expected 3");
      const int base = static_cast<int>(b.v.size() / 3) - 3;
      b.tri(base, base + 1, base + 2);
      in_loop = 0;
    } else if (tok == "facet" || tok == "normal" || tok == "outer" || tok == "loop" || tok == "endfacet" ||
               tok == "solid" || tok == "endsolid") {
      if (tok == "normal") {  // skip three numbers (may be nan in some exporters)
        std::string a, c, e;
        in >> a >> c >> e;
      }
      if (tok == "solid" || tok == "endsolid") std::getline(in, tok);  // name
    } else {
      fail(path, "unexpected token '" + tok.substr(0, 20) + "' in ascii STL");
    }
  }
  if (in_loop != 0) fail(path, "ascii STL ends inside a facet (truncated)");
  return b.finish(path);
}

TriangleMesh read_obj(const std::string& path) {
  const std::string d = read_all(path);
  std::istringstream in(d);
  std::string line;
  Builder b;
  std::size_t lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    std::istringstream ls(line);
    std::string tag;
    if (!(ls >> tag)) continue;
    if (tag == "v") {
      double x, y, z;
      if (!(read_double(ls, x) && read_double(ls, y) && read_double(ls, z))) fail(path, "line " + std::to_string(lineno) + ": malformed vertex");
      b.vertex(x, y, z);
    } else if (tag == "f") {
      std::vector<int> idx;
      std::string w;
      while (ls >> w) {
        const long k = std::strtol(w.c_str(), nullptr, 10);  // "7/1/3" -> 7
        const long nv = static_cast<long>(b.v.size() / 3);
        const long i = k < 0 ? nv + k : k - 1;
        if (k == 0 || i < 0 || i >= nv) fail(path, "line " + std::to_string(lineno) + ": face index " + w + " out of range");
        idx.push_back(static_cast<int>(i));
      }
      if (idx.size() < 3) fail(path, "line " + std::to_string(lineno) + ": face with fewer than 3 vertices");
      b.polygon(idx, path, "line " + std::to_string(lineno));
    } else if (tag.size() == 1 || tag == "vn" || tag == "vt" || tag == "vp" || tag == "usemtl" || tag == "mtllib" ||
               tag[0] == '#') {
      continue;
    } else {
      fail(path, "line " + std::to_string(lineno) + ": not an OBJ statement ('" + tag.substr(0, 20) + "')");
    }
  }
  return b.finish(path);
}

template <typename T>
T swap_bytes(T v) {
  char* p = reinterpret_cast<char*>(&v);
  std::reverse(p, p + sizeof(T));
  return v;
}

TriangleMesh read_ply(const std::string& path) {
  const std::string d = read_all(path);
  if (d.compare(0, 3, "ply") != 0) fail(path, "not a PLY file (no 'ply' magic)");
  const std::size_t hend = d.find("end_header");
  if (hend == std::string::npos) fail(path, "PLY header has no end_header (truncated?)");
  std::size_t body = d.find('\n', hend);
  if (body == std::string::npos) fail(path, "PLY file ends after its header");
  ++body;
  std::istringstream hs(d.substr(0, hend));
  std::string line, format;
  struct Prop { std::string type, count_type; bool list = false; std::string name; };
  struct Elem { std::string name; std::size_t count = 0; std::vector<Prop> props; };
  std::vector<Elem> elems;
  while (std::getline(hs, line)) {
    std::istringstream ls(line);
    std::string w;
    ls >> w;
    if (w == "format") ls >> format;
    else if (w == "element") { Elem e; ls >> e.name >> e.count; elems.push_back(e); }
    else if (w == "property") {
      if (elems.empty()) fail(path, "PLY property before any element");
      Prop p;
      ls >> p.type;
      if (p.type == "list") { p.list = true; ls >> p.count_type >> p.type; }
      ls >> p.name;
      elems.back().props.push_back(p);
    }
  }
  if (format != "ascii" && format != "binary_little_endian" && format != "binary_big_endian")
    fail(path, "unsupported PLY format '" + format + "'");
  const bool ascii = format == "ascii";
  const bool swap = format == "binary_big_endian";
  auto tsize = [&](const std::string& t) -> std::size_t {
    if (t == "char" || t == "uchar" || t == "int8" || t == "uint8") return 1;
    if (t == "short" || t == "ushort" || t == "int16" || t == "uint16") return 2;
    if (t == "int" || t == "uint" || t == "float" || t == "int32" || t == "uint32" || t == "float32") return 4;
    if (t == "double" || t == "float64") return 8;
    fail(path, "unknown PLY property type '" + t + "'");
  };
  std::size_t pos = body;
  std::istringstream as(ascii ? d.substr(body) : std::string());
  auto read_num = [&](const std::string& t) -> double {
    if (ascii) {
      double x;
      if (!read_double(as, x)) fail(path, "PLY data ends early or is not a number (truncated?)");
      return x;
    }
    const std::size_t n = tsize(t);
    if (pos + n > d.size()) fail(path, "PLY data ends early (truncated)");
    const char* p = d.data() + pos;
    pos += n;
    auto get = [&](auto dummy) {
      decltype(dummy) v;
      std::memcpy(&v, p, sizeof(v));
      return static_cast<double>(swap ? swap_bytes(v) : v);
    };
    if (t == "char" || t == "int8") return get(std::int8_t{});
    if (t == "uchar" || t == "uint8") return get(std::uint8_t{});
    if (t == "short" || t == "int16") return get(std::int16_t{});
    if (t == "ushort" || t == "uint16") return get(std::uint16_t{});
    if (t == "int" || t == "int32") return get(std::int32_t{});
    if (t == "uint" || t == "uint32") return get(std::uint32_t{});
    if (t == "float" || t == "float32") return get(float{});
    return get(double{});
  };
  Builder b;
  std::size_t nverts = 0;
  for (const Elem& e : elems) {
    if (e.count > d.size()) fail(path, "PLY element '" + e.name + "' count larger than the file");
    for (std::size_t i = 0; i < e.count; ++i) {
      double xyz[3] = {0, 0, 0};
      for (const Prop& p : e.props) {
        if (p.list) {
          const double n = read_num(p.count_type);
          if (!(n >= 0 && n <= 1000) || n != std::floor(n)) fail(path, "PLY list of " + std::to_string(n) + " entries");
          const bool face = e.name == "face" && (p.name == "vertex_indices" || p.name == "vertex_index");
          std::vector<int> idx;
          for (int k = 0; k < static_cast<int>(n); ++k) {
            const double x = read_num(p.type);
            if (!face) continue;
            // range-checked as a double: casting an out-of-range value to int is undefined
            if (!(x >= 0 && x < static_cast<double>(nverts)) || x != std::floor(x))
              fail(path, "PLY face " + std::to_string(i + 1) + ": vertex index " + std::to_string(x) + " out of range");
            idx.push_back(static_cast<int>(x));
          }
          if (face) b.polygon(idx, path, "PLY face " + std::to_string(i + 1));
        } else {
          const double x = read_num(p.type);
          if (e.name == "vertex") {
            if (p.name == "x") xyz[0] = x;
            if (p.name == "y") xyz[1] = x;
            if (p.name == "z") xyz[2] = x;
          }
        }
      }
      if (e.name == "vertex") { b.vertex(xyz[0], xyz[1], xyz[2]); ++nverts; }
    }
  }
  return b.finish(path);
}

TriangleMesh read_mesh_file(const std::string& path, const std::string& ext) {
  if (ext == "stl") return read_stl(path);
  if (ext == "obj") return read_obj(path);
  return read_ply(path);
}

}  // namespace

std::size_t orient_consistently(TriangleMesh& m) {
  const Eigen::Index T = m.triangles.rows();
  if (T == 0) return 0;
  // Weld vertices by position so that faces written separately (B-rep faces, STEP face compounds)
  // become neighbours across their shared edges.
  const double q = std::max(1e-12, 1e-7 * m.diagonal());
  std::unordered_map<std::string, int> ids;
  std::vector<int> weld(static_cast<std::size_t>(m.vertices.rows()));
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) {
    char key[64];
    std::snprintf(key, sizeof(key), "%lld %lld %lld", static_cast<long long>(std::llround(m.vertices(v, 0) / q)),
                  static_cast<long long>(std::llround(m.vertices(v, 1) / q)), static_cast<long long>(std::llround(m.vertices(v, 2) / q)));
    weld[static_cast<std::size_t>(v)] = ids.emplace(key, static_cast<int>(ids.size())).first->second;
  }
  // Edge -> triangles using it, with the direction they traverse it.
  std::unordered_map<std::uint64_t, std::vector<std::pair<int, bool>>> edges;
  for (Eigen::Index t = 0; t < T; ++t)
    for (int k = 0; k < 3; ++k) {
      const std::uint64_t a = static_cast<std::uint64_t>(weld[static_cast<std::size_t>(m.triangles(t, k))]);
      const std::uint64_t b = static_cast<std::uint64_t>(weld[static_cast<std::size_t>(m.triangles(t, (k + 1) % 3))]);
      if (a == b) continue;
      edges[a < b ? (a << 32 | b) : (b << 32 | a)].push_back({static_cast<int>(t), a < b});
    }
  std::vector<std::vector<std::pair<int, bool>>> adj(static_cast<std::size_t>(T));  // neighbour, same direction?
  std::vector<std::uint64_t> keys;  // sorted: the walk below must not depend on hash order
  keys.reserve(edges.size());
  for (const auto& e : edges) keys.push_back(e.first);
  std::sort(keys.begin(), keys.end());
  for (const std::uint64_t key : keys) {
    const auto& uses = edges[key];
    if (uses.size() != 2) continue;  // boundary or non-manifold edge: no constraint
    const auto& x = uses[0];
    const auto& y = uses[1];
    adj[static_cast<std::size_t>(x.first)].push_back({y.first, x.second == y.second});
    adj[static_cast<std::size_t>(y.first)].push_back({x.first, x.second == y.second});
  }
  std::vector<signed char> flip(static_cast<std::size_t>(T), -1);
  std::size_t flipped = 0;
  for (Eigen::Index s = 0; s < T; ++s) {
    if (flip[static_cast<std::size_t>(s)] >= 0) continue;
    std::vector<int> comp{static_cast<int>(s)};
    flip[static_cast<std::size_t>(s)] = 0;
    for (std::size_t i = 0; i < comp.size(); ++i) {
      const int t = comp[i];
      for (const auto& n : adj[static_cast<std::size_t>(t)]) {
        // two triangles traversing a shared edge in the same direction disagree in orientation
        const signed char want = static_cast<signed char>(flip[static_cast<std::size_t>(t)] ^ (n.second ? 1 : 0));
        if (flip[static_cast<std::size_t>(n.first)] < 0) {
          flip[static_cast<std::size_t>(n.first)] = want;
          comp.push_back(n.first);
        }
      }
    }
    // The orientation most of the component's area already has wins.
    double keep_area = 0, flip_area = 0;
    for (int t : comp) {
      const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)), b = m.vertices.row(m.triangles(t, 1)), c = m.vertices.row(m.triangles(t, 2));
      (flip[static_cast<std::size_t>(t)] ? flip_area : keep_area) += (b - a).cross(c - a).norm();
    }
    const bool invert = flip_area > keep_area;
    for (int t : comp) {
      const bool f = (flip[static_cast<std::size_t>(t)] != 0) != invert;
      flip[static_cast<std::size_t>(t)] = 2;  // done
      if (f) {
        std::swap(m.triangles(t, 1), m.triangles(t, 2));
        ++flipped;
      }
    }
  }
  return flipped;
}

namespace {

// Corrupt coordinates (one float turned into 1e12, integer bit patterns read as coordinates) make a
// bounding box far larger than the mesh's own detail; every stage's work grows with it. A real part
// spans at most some 10^4 of its median edge (a 5 m body meshed at 0.5 mm): past 10^6 the file is
// refused, naming the vertex farthest from the mesh's median point.
void check_extent(const TriangleMesh& m, const std::string& name) {
  const double diag = m.diagonal();
  std::vector<double> edges;
  const Eigen::Index step = std::max<Eigen::Index>(1, m.triangles.rows() / 20000);
  for (Eigen::Index t = 0; t < m.triangles.rows(); t += step)
    for (int k = 0; k < 3; ++k) {
      const double e = (m.vertices.row(m.triangles(t, k)) - m.vertices.row(m.triangles(t, (k + 1) % 3))).norm();
      if (e > 0) edges.push_back(e);
    }
  if (edges.empty()) return;
  std::nth_element(edges.begin(), edges.begin() + static_cast<long>(edges.size() / 2), edges.end());
  const double median = edges[edges.size() / 2];
  if (!(diag > 1e6 * median)) return;
  Eigen::Vector3d mid;
  for (int a = 0; a < 3; ++a) {
    std::vector<double> c;
    c.reserve(static_cast<std::size_t>(m.vertices.rows()));
    for (Eigen::Index i = 0; i < m.vertices.rows(); ++i) c.push_back(m.vertices(i, a));
    std::nth_element(c.begin(), c.begin() + static_cast<long>(c.size() / 2), c.end());
    mid(a) = c[c.size() / 2];
  }
  Eigen::Index far = 0;
  (m.vertices.rowwise() - mid.transpose()).rowwise().squaredNorm().maxCoeff(&far);
  std::ostringstream s;
  s.precision(4);
  s << "coordinates look corrupt: the bounding box (diagonal " << diag << ") is over a million times the median edge ("
    << median << "); vertex " << far + 1 << " lies at (" << m.vertices(far, 0) << ", " << m.vertices(far, 1) << ", "
    << m.vertices(far, 2) << ")";
  fail(name, s.str());
}

}  // namespace

void validate_mesh(TriangleMesh& m) {
  const std::string& name = m.source.empty() ? std::string("<mesh>") : m.source;
  if (m.vertices.rows() == 0 || m.triangles.rows() == 0) fail(name, "no triangles");
  if (m.face_ids.size() != m.triangles.rows()) m.face_ids = Eigen::VectorXi::Zero(m.triangles.rows());
  if (m.face_ids.size() > 0) {
    // face ids are 1-based FaceN numbers (0 = none); the face tables are sized by the largest one
    const int lo = m.face_ids.minCoeff(), hi = m.face_ids.maxCoeff();
    if (lo < 0) fail(name, "negative face id " + std::to_string(lo));
    if (hi > std::max<Eigen::Index>(m.triangles.rows(), m.num_faces)) fail(name, "face id " + std::to_string(hi) + " exceeds the triangle count (" +
                                                std::to_string(m.triangles.rows()) + "): ids must number faces 1..n");
    m.num_faces = std::max(m.num_faces, hi);
  }
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i)
    if (!m.vertices.row(i).allFinite())
      fail(name, "non-finite (NaN or infinite) coordinate at vertex " + std::to_string(i + 1));
  const int nv = static_cast<int>(m.vertices.rows());
  for (Eigen::Index t = 0; t < m.triangles.rows(); ++t)
    for (int k = 0; k < 3; ++k)
      if (m.triangles(t, k) < 0 || m.triangles(t, k) >= nv)
        fail(name, "triangle " + std::to_string(t + 1) + " refers to missing vertex " + std::to_string(m.triangles(t, k)));
  check_extent(m, name);
  std::vector<Eigen::Index> keep;
  keep.reserve(static_cast<std::size_t>(m.triangles.rows()));
  const double diag = m.diagonal();
  const double min_area = std::pow(diag * 1e-9, 2);
  for (Eigen::Index t = 0; t < m.triangles.rows(); ++t) {
    const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)), b = m.vertices.row(m.triangles(t, 1)),
                          c = m.vertices.row(m.triangles(t, 2));
    if (0.5 * (b - a).cross(c - a).norm() > min_area) keep.push_back(t);
  }
  m.dropped_degenerate += static_cast<std::size_t>(m.triangles.rows()) - keep.size();
  if (keep.empty()) fail(name, "all " + std::to_string(m.triangles.rows()) + " triangles have zero area");
  if (keep.size() != static_cast<std::size_t>(m.triangles.rows())) {
    Triangles t2(static_cast<Eigen::Index>(keep.size()), 3);
    Eigen::VectorXi f2(static_cast<Eigen::Index>(keep.size()));
    for (std::size_t i = 0; i < keep.size(); ++i) {
      t2.row(static_cast<Eigen::Index>(i)) = m.triangles.row(keep[i]);
      f2(static_cast<Eigen::Index>(i)) = m.face_ids(keep[i]);
    }
    m.triangles = std::move(t2);
    m.face_ids = std::move(f2);
  }
  if (!(diag > 0) || !std::isfinite(diag)) fail(name, "shape has zero size");
  m.reoriented = orient_consistently(m);
}

// B-rep formats are handled in brep_io.cpp.
TriangleMesh read_brep_file(const std::string& path, const std::string& ext, const TessellationOptions& o);

TriangleMesh read_shape(const std::string& path, const TessellationOptions& options) {
  const std::string ext = file_extension(path);
  {
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) fail(path, "is a folder, not a file");
  }
  TriangleMesh m;
  if (ext == "stl" || ext == "obj" || ext == "ply") {
    m = read_mesh_file(path, ext);
  } else if (ext == "step" || ext == "stp" || ext == "iges" || ext == "igs" || ext == "brep" || ext == "brp") {
    {
      std::ifstream in(path, std::ios::binary);
      if (!in) fail(path, "cannot open file (missing or unreadable)");
      if (in.peek() == std::ifstream::traits_type::eof()) fail(path, "file is empty");
    }
    m = read_brep_file(path, ext, options);
  } else {
    fail(path, "unknown file type '." + ext + "' (expected .step .stp .iges .igs .brep .brp .stl .obj .ply)");
  }
  m.source = path;
  validate_mesh(m);
  return m;
}

void write_stl(const TriangleMesh& m, const std::string& path, bool binary) {
  std::ofstream out(path, std::ios::binary);
  if (!out) throw std::runtime_error(path + ": cannot write");
  auto normal = [&](Eigen::Index t) {
    const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)), b = m.vertices.row(m.triangles(t, 1)),
                          c = m.vertices.row(m.triangles(t, 2));
    Eigen::Vector3d n = (b - a).cross(c - a);
    return n.norm() > 0 ? Eigen::Vector3d(n.normalized()) : n;
  };
  if (binary) {
    char header[80] = "FeatureExtract binary STL";
    out.write(header, 80);
    const std::uint32_t n = static_cast<std::uint32_t>(m.triangles.rows());
    out.write(reinterpret_cast<const char*>(&n), 4);
    for (Eigen::Index t = 0; t < m.triangles.rows(); ++t) {
      float rec[12];
      const Eigen::Vector3d nn = normal(t);
      for (int k = 0; k < 3; ++k) rec[k] = static_cast<float>(nn[k]);
      for (int v = 0; v < 3; ++v)
        for (int k = 0; k < 3; ++k) rec[3 + 3 * v + k] = static_cast<float>(m.vertices(m.triangles(t, v), k));
      out.write(reinterpret_cast<const char*>(rec), sizeof(rec));
      const std::uint16_t attr = 0;
      out.write(reinterpret_cast<const char*>(&attr), 2);
    }
  } else {
    out << "solid featureextract\n";
    out.precision(9);
    for (Eigen::Index t = 0; t < m.triangles.rows(); ++t) {
      const Eigen::Vector3d nn = normal(t);
      out << " facet normal " << nn.x() << ' ' << nn.y() << ' ' << nn.z() << "\n  outer loop\n";
      for (int v = 0; v < 3; ++v) {
        const auto p = m.vertices.row(m.triangles(t, v));
        out << "   vertex " << p(0) << ' ' << p(1) << ' ' << p(2) << "\n";
      }
      out << "  endloop\n endfacet\n";
    }
    out << "endsolid featureextract\n";
  }
  if (!out) throw std::runtime_error(path + ": write failed");
}

}  // namespace fe
