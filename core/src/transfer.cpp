// Reference feature folders and the transfer of a reference FE mesh onto a found instance (issue 5).
#include "featureextract/transfer.h"

#include "featureextract/geometry.h"

#include <nlohmann/json.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace fe {

namespace {

[[noreturn]] void fail(const std::string& where, const std::string& what) { throw InputError(where + ": " + what); }


}  // namespace

Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c) {
  // Voronoi regions of the triangle (Ericson, Real-Time Collision Detection, 5.1.5)
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return a;
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return b;
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return a + (d1 / (d1 - d3)) * ab;
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return c;
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return a + (d2 / (d2 - d6)) * ac;
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return b + ((d4 - d3) / ((d4 - d3) + (d5 - d6))) * (c - b);
  const double denom = 1.0 / (va + vb + vc);
  return a + ab * (vb * denom) + ac * (vc * denom);
}

namespace {

// The parts of a specification the mesh steps read ("rules", "axis", "element", "analysis"), checked
// once where the file is known (read_feature, which `library check` calls too), so that a malformed
// one is a one-line error naming feature.json and not an exception from deep inside `mesh` or
// `mesh-part`; the readers downstream may take these shapes as given.
void check_spec(const nlohmann::json& j, const std::string& spec_path) {
  auto vec3 = [&](const nlohmann::json& v, const std::string& what) {
    if (!v.is_array() || v.size() != 3 || !std::all_of(v.begin(), v.end(), [](const nlohmann::json& x) { return x.is_number(); }))
      fail(spec_path, what + " must be an array of 3 numbers");
  };
  if (j.contains("axis")) {
    const auto& a = j["axis"];
    if (!a.is_object() || !a.contains("point") || !a.contains("direction")) fail(spec_path, "\"axis\" must be an object with \"point\" and \"direction\"");
    vec3(a["point"], "\"axis\".\"point\"");
    vec3(a["direction"], "\"axis\".\"direction\"");
    const double n = std::hypot(a["direction"][0].get<double>(), a["direction"][1].get<double>(), a["direction"][2].get<double>());
    if (!(n > 0) || !std::isfinite(n)) fail(spec_path, "\"axis\".\"direction\" must not be zero");
  }
  if (j.contains("element")) {
    if (!j["element"].is_object()) fail(spec_path, "\"element\" must be an object");
    if (j["element"].contains("size") && !j["element"]["size"].is_number()) fail(spec_path, "\"element\".\"size\" must be a number");
  }
  if (j.contains("analysis")) {
    if (!j["analysis"].is_array()) fail(spec_path, "\"analysis\" must be an array");
    for (std::size_t i = 0; i < j["analysis"].size(); ++i) {
      const auto& an = j["analysis"][i];
      const std::string at = "\"analysis\"[" + std::to_string(i) + "]";
      if (!an.is_object()) fail(spec_path, at + " must be an object");
      for (const char* key : {"kind", "node_set"})
        if (an.contains(key) && !an[key].is_string()) fail(spec_path, at + ".\"" + key + "\" must be a string");
    }
  }
  if (!j.contains("rules")) return;
  if (!j["rules"].is_array()) fail(spec_path, "\"rules\" must be an array");
  for (std::size_t i = 0; i < j["rules"].size(); ++i) {
    const auto& r = j["rules"][i];
    const std::string at = "\"rules\"[" + std::to_string(i) + "]";
    if (!r.is_object() || !r.contains("rule") || !r["rule"].is_string()) fail(spec_path, at + " must be an object with a string \"rule\"");
    for (const char* key : {"angle_step_deg", "start_angle_deg", "width", "size"})
      if (r.contains(key) && !r[key].is_number()) fail(spec_path, at + ".\"" + key + "\" must be a number");
    const std::string name = r["rule"].get<std::string>();
    if (name == "nodes_on_circles") {
      if (!j.contains("axis")) fail(spec_path, at + " (nodes_on_circles) needs the feature's \"axis\"");
      if (r.contains("angle_step_deg") && !(r["angle_step_deg"].get<double>() > 0 && r["angle_step_deg"].get<double>() <= 360))
        fail(spec_path, at + ".\"angle_step_deg\" must be in (0, 360]");
    }
    if (name == "transition_zone" && !(r.contains("width") && r["width"].get<double>() > 0 && std::isfinite(r["width"].get<double>())))
      fail(spec_path, at + " (transition_zone) needs a positive \"width\"");
  }
}

}  // namespace

FeatureModel read_feature(const std::string& dir) {
  namespace fs = std::filesystem;
  FeatureModel f;
  f.dir = dir;
  const std::string spec_path = (fs::path(dir) / "feature.json").string();
  std::ifstream in(spec_path);
  if (!fs::is_directory(dir)) fail(dir, "not a folder (a reference feature is a folder with feature.json)");
  if (!in) fail(spec_path, "cannot open (a reference feature folder needs feature.json)");
  std::stringstream ss;
  ss << in.rdbuf();
  f.spec_json = ss.str();
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(f.spec_json);
  } catch (const std::exception& e) {
    fail(spec_path, std::string("not valid JSON: ") + e.what());
  }
  if (!j.is_object()) fail(spec_path, "must hold a JSON object");
  for (const char* key : {"geometry", "mesh"})
    if (!j.contains(key) || !j[key].is_string()) fail(spec_path, std::string("needs \"") + key + "\": a file name in the folder");
  if (j.contains("name") && !j["name"].is_string()) fail(spec_path, "\"name\" must be a string");
  check_spec(j, spec_path);
  f.name = j.value("name", fs::path(dir).filename().string());
  f.geometry_path = (fs::path(dir) / j["geometry"].get<std::string>()).string();
  f.mesh_path = (fs::path(dir) / j["mesh"].get<std::string>()).string();
  for (const std::string* file : {&f.geometry_path, &f.mesh_path}) {
    std::error_code ec;
    const bool there = fs::is_regular_file(*file, ec);
    if (ec && ec != std::errc::no_such_file_or_directory)
      fail(spec_path, "file " + fs::path(*file).filename().string().substr(0, 60) + (fs::path(*file).filename().string().size() > 60 ? "..." : "") +
                          " cannot be opened: " + ec.message());
    if (!there) fail(spec_path, "file " + *file + " does not exist");
  }
  f.mesh = read_fe_mesh(f.mesh_path);
  if (f.mesh.num_elements() == 0) fail(f.mesh_path, "mesh has no elements");
  return f;
}

TransferredMesh transfer_mesh(const FeMesh& reference, const Eigen::Matrix4d& H, const TriangleMesh& target,
                              const TransferOptions& o, const std::string& spec_json) {
  TransferredMesh out;
  out.mesh = reference;
  const Eigen::Index N = reference.nodes.rows();
  if (N == 0) throw std::invalid_argument("transfer_mesh: the reference mesh has no nodes");
  // A mirrored instance (H a reflection) turns every element inside out: reverse the node order so
  // that shell normals (and solid volumes) keep their sign. The first node stays first.
  {
    const Eigen::Vector3d c = 0.5 * (reference.nodes.colwise().minCoeff() + reference.nodes.colwise().maxCoeff()).transpose();
    out.reversed = transform_jacobian(H, c).determinant() < 0;
    if (out.reversed)
      for (ElementBlock& b : out.mesh.blocks) {
        std::vector<int> order;
        switch (b.type) {
          case ElementType::Tri3: order = {0, 2, 1}; break;
          case ElementType::Quad4: order = {0, 3, 2, 1}; break;
          case ElementType::Tet4: order = {0, 2, 1, 3}; break;
          case ElementType::Hex8: order = {0, 3, 2, 1, 4, 7, 6, 5}; break;
          case ElementType::Tet10: order = {0, 2, 1, 3, 6, 5, 4, 7, 9, 8}; break;  // corners 1, 2 swapped; their edges follow
        }
        const auto conn = b.conn;
        for (Eigen::Index r = 0; r < conn.rows(); ++r)
          for (std::size_t k = 0; k < order.size(); ++k) b.conn(r, static_cast<Eigen::Index>(k)) = conn(r, order[k]);
      }
  }

  // Node normals of the reference (area-weighted element normals), mapped with the inverse transpose.
  Points node_n = Points::Zero(N, 3);
  for (const ElementBlock& b : reference.blocks) {
    if (!is_shell(b.type)) continue;
    for (Eigen::Index e = 0; e < b.conn.rows(); ++e) {
      const Eigen::Vector3d x0 = reference.nodes.row(b.conn(e, 0)), x1 = reference.nodes.row(b.conn(e, 1)),
                            x2 = reference.nodes.row(b.conn(e, 2));
      Eigen::Vector3d n = (x1 - x0).cross(x2 - x0);
      if (b.type == ElementType::Quad4) n = (x2 - x0).cross(reference.nodes.row(b.conn(e, 3)).transpose() - x1);
      for (Eigen::Index k = 0; k < b.conn.cols(); ++k) node_n.row(b.conn(e, k)) += n.transpose();
    }
  }
  Points mapped(N, 3), mapped_n = Points::Zero(N, 3);
  for (Eigen::Index i = 0; i < N; ++i) {
    const Eigen::Vector3d x = reference.nodes.row(i);
    const Eigen::Vector3d y = apply_transform(H, x);
    if (!y.allFinite()) throw std::invalid_argument("transfer_mesh: the transform sends a node to infinity");
    mapped.row(i) = y;
    const Eigen::Vector3d n = node_n.row(i);
    if (n.norm() > 0) {
      const Eigen::Vector3d m = transform_jacobian(H, x).inverse().transpose() * n;
      if (m.allFinite() && m.norm() > 0) mapped_n.row(i) = m.normalized();
    }
  }
  out.mesh.nodes = mapped;  // nodes that find no foot point keep H's position
  // Reach of the projection: relative to the reference mesh's size times the local scale of H (not
  // the mapped box, which a bad transform can blow up).
  const Eigen::Vector3d rc = 0.5 * (reference.nodes.colwise().minCoeff() + reference.nodes.colwise().maxCoeff()).transpose();
  const double scale_h = std::cbrt(std::abs(transform_jacobian(H, rc).determinant()));
  const double reach = o.max_projection * (reference.nodes.colwise().maxCoeff() - reference.nodes.colwise().minCoeff()).norm() *
                       (std::isfinite(scale_h) && scale_h > 0 ? scale_h : 1.0);
  const Eigen::Vector3d lo = mapped.colwise().minCoeff(), hi = mapped.colwise().maxCoeff();

  // Target triangles near the mapped mesh.
  std::vector<Eigen::Index> region;
  const bool by_face = !o.faces.empty() && target.face_ids.size() == target.triangles.rows();
  for (Eigen::Index t = 0; t < target.triangles.rows(); ++t) {
    if (by_face && !std::binary_search(o.faces.begin(), o.faces.end(), target.face_ids(t))) continue;
    Eigen::Vector3d tlo = target.vertices.row(target.triangles(t, 0)), thi = tlo;
    for (int k = 1; k < 3; ++k) {
      tlo = tlo.cwiseMin(target.vertices.row(target.triangles(t, k)).transpose());
      thi = thi.cwiseMax(target.vertices.row(target.triangles(t, k)).transpose());
    }
    if ((thi.array() < (lo.array() - reach)).any() || (tlo.array() > (hi.array() + reach)).any()) continue;
    region.push_back(t);
  }
  std::vector<Eigen::Vector3d> tn(region.size());
  for (std::size_t r = 0; r < region.size(); ++r) {
    const Eigen::Index t = region[r];
    const Eigen::Vector3d a = target.vertices.row(target.triangles(t, 0)), b = target.vertices.row(target.triangles(t, 1)),
                          c = target.vertices.row(target.triangles(t, 2));
    const Eigen::Vector3d n = (b - a).cross(c - a);
    tn[r] = n.norm() > 0 ? Eigen::Vector3d(n.normalized()) : Eigen::Vector3d::Zero();
  }
  auto corner = [&](std::size_t r, int k) -> Eigen::Vector3d { return target.vertices.row(target.triangles(region[r], k)); };

  // Foot point of y on the target: the closest point within reach on a triangle whose normal agrees
  // with m (else on any triangle); false if none is within reach.
  auto foot = [&](const Eigen::Vector3d& y, const Eigen::Vector3d& m, Eigen::Vector3d& out_q) {
    double best_agree = INFINITY, best_any = INFINITY;
    Eigen::Vector3d q_agree = y, q_any = y;
    for (std::size_t r = 0; r < region.size(); ++r) {
      const Eigen::Vector3d q = closest_point_on_triangle(y, corner(r, 0), corner(r, 1), corner(r, 2));
      const double d = (q - y).norm();
      if (d > reach) continue;
      if (d < best_any) { best_any = d; q_any = q; }
      if (d < best_agree && (m.isZero() || tn[r].dot(m) >= o.normal_agreement)) { best_agree = d; q_agree = q; }
    }
    if (!std::isfinite(best_agree) && !std::isfinite(best_any)) return false;
    out_q = std::isfinite(best_agree) ? q_agree : q_any;
    return true;
  };
  std::vector<char> on_surface(static_cast<std::size_t>(N), 0);
  for (Eigen::Index i = 0; i < N; ++i) {
    Eigen::Vector3d q;
    if (foot(mapped.row(i).transpose(), mapped_n.row(i).transpose(), q)) {
      out.mesh.nodes.row(i) = q.transpose();
      on_surface[static_cast<std::size_t>(i)] = 1;
    }
  }
  // Quality before and after; shells judged against their own normals mapped by H.
  out.before = element_quality(reference);
  const Points n0 = element_normals(reference);
  Points n1 = Points::Zero(n0.rows(), 3);
  Eigen::Index e = 0;
  for (const ElementBlock& b : reference.blocks)
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r, ++e) {
      if (!is_shell(b.type) || n0.row(e).isZero()) continue;
      Eigen::Vector3d c = Eigen::Vector3d::Zero();
      for (Eigen::Index k = 0; k < b.conn.cols(); ++k) c += reference.nodes.row(b.conn(r, k)).transpose();
      c /= static_cast<double>(b.conn.cols());
      const Eigen::Vector3d m = transform_jacobian(H, c).inverse().transpose() * n0.row(e).transpose();
      if (m.allFinite() && m.norm() > 0) n1.row(e) = m.normalized();
    }
  out.after = element_quality(out.mesh, &n1);
  // Morph with the border: a fit a fraction of an element off puts the mesh's outer rows past the
  // target's face; their foot points stop on the face's edge and rows fold onto it (NIST CTC-02's
  // mirrored lugs: three rows on the root edge). Where a border node's foot lies along the face (not
  // along its normal) by more than a tenth of an element, every border node's move onto the target is
  // spread over the interior as a harmonic displacement (Gauss-Seidel on the element graph), and the
  // interior is projected again from there. Kept only if fewer elements fall below 0.3 (or as many,
  // with a better worst one).
  {
    std::map<std::pair<int, int>, int> uses;
    std::vector<std::vector<int>> nb(static_cast<std::size_t>(N));
    double edge_sum = 0;
    std::size_t edge_n = 0;
    for (const ElementBlock& b : reference.blocks) {
      if (!is_shell(b.type)) continue;
      const int k = b.type == ElementType::Quad4 ? 4 : 3;
      for (Eigen::Index r = 0; r < b.conn.rows(); ++r)
        for (int c = 0; c < k; ++c) {
          const int a = b.conn(r, c), d = b.conn(r, (c + 1) % k);
          ++uses[{std::min(a, d), std::max(a, d)}];
          nb[static_cast<std::size_t>(a)].push_back(d);
          nb[static_cast<std::size_t>(d)].push_back(a);
          edge_sum += (mapped.row(a) - mapped.row(d)).norm();
          ++edge_n;
        }
    }
    std::vector<char> border(static_cast<std::size_t>(N), 0);
    std::vector<std::vector<int>> chain(static_cast<std::size_t>(N));  // neighbours along the border
    for (const auto& [ed, n] : uses)
      if (n == 1) {
        border[static_cast<std::size_t>(ed.first)] = border[static_cast<std::size_t>(ed.second)] = 1;
        chain[static_cast<std::size_t>(ed.first)].push_back(ed.second);
        chain[static_cast<std::size_t>(ed.second)].push_back(ed.first);
      }
    const double h = edge_n ? edge_sum / static_cast<double>(edge_n) : 0.0;
    double overhang = 0;
    for (Eigen::Index i = 0; i < N; ++i) {
      if (!border[static_cast<std::size_t>(i)] || !on_surface[static_cast<std::size_t>(i)]) continue;
      const Eigen::Vector3d d = (out.mesh.nodes.row(i) - mapped.row(i)).transpose(), m = mapped_n.row(i).transpose();
      overhang = std::max(overhang, (d - d.dot(m) * m).norm());
    }
    if (h > 0 && overhang > 0.1 * h) {
      // the border nodes hold their move, except where two neighbours along the border came within
      // 0.3 of their spacing (stopped on the same stretch of the face's edge, at a corner): those
      // follow the interior, and the mesher puts them onto the edge in order
      std::vector<char> fixed(static_cast<std::size_t>(N), 0);
      for (Eigen::Index i = 0; i < N; ++i) fixed[static_cast<std::size_t>(i)] = border[static_cast<std::size_t>(i)] && on_surface[static_cast<std::size_t>(i)];
      for (Eigen::Index i = 0; i < N; ++i)
        for (const int j : chain[static_cast<std::size_t>(i)])
          if ((out.mesh.nodes.row(i) - out.mesh.nodes.row(j)).norm() < 0.3 * (mapped.row(i) - mapped.row(j)).norm())
            fixed[static_cast<std::size_t>(i)] = fixed[static_cast<std::size_t>(j)] = 0;
      Points u = Points::Zero(N, 3);
      for (Eigen::Index i = 0; i < N; ++i)
        if (fixed[static_cast<std::size_t>(i)]) u.row(i) = out.mesh.nodes.row(i) - mapped.row(i);
      for (int it = 0; it < 2000; ++it) {
        double change = 0;
        for (Eigen::Index i = 0; i < N; ++i) {
          const auto& ns = nb[static_cast<std::size_t>(i)];
          if (fixed[static_cast<std::size_t>(i)] || ns.empty()) continue;
          Eigen::RowVector3d mean = Eigen::RowVector3d::Zero();
          for (const int v : ns) mean += u.row(v);
          mean /= static_cast<double>(ns.size());
          change = std::max(change, (mean - u.row(i)).norm());
          u.row(i) = mean;
        }
        if (change < 1e-4 * h) break;
      }
      FeMesh trial = out.mesh;
      std::vector<char> trial_on = on_surface;
      std::size_t moved_n = 0;
      for (Eigen::Index i = 0; i < N; ++i) {
        if (fixed[static_cast<std::size_t>(i)]) continue;
        Eigen::Vector3d q;
        if (foot(mapped.row(i).transpose() + u.row(i).transpose(), mapped_n.row(i).transpose(), q)) {
          trial.nodes.row(i) = q.transpose();
          trial_on[static_cast<std::size_t>(i)] = 1;
          moved_n += (q - out.mesh.nodes.row(i).transpose()).norm() > 1e-9 * h;
        }
      }
      const std::vector<ElementQuality> tq = element_quality(trial, &n1);
      auto poor = [&](const std::vector<ElementQuality>& qq, double* worst) {
        std::size_t n = 0;
        *worst = INFINITY;
        for (std::size_t e2 = 0; e2 < qq.size(); ++e2) {
          if (out.before[e2].scaled_jacobian < 0.3) continue;  // poor already in the reference
          n += qq[e2].scaled_jacobian < 0.3;
          *worst = std::min(*worst, qq[e2].scaled_jacobian);
        }
        return n;
      };
      double w0 = 0, w1 = 0;
      const std::size_t p0 = poor(out.after, &w0), p1 = poor(tq, &w1);
      if (p1 < p0 || (p1 == p0 && w1 > w0 + 1e-9)) {
        out.mesh.nodes = trial.nodes;
        on_surface = trial_on;
        out.after = tq;
        out.morphed = moved_n;
      }
    }
  }
  // Untangling: closest-point projection can fold a small element where the target's shape differs
  // from the mapped reference (a fillet of another radius). The nodes of such elements are moved to
  // the mean of their neighbours and projected again, a few rounds; elements valid before only.
  {
    std::vector<std::vector<int>> nbr(static_cast<std::size_t>(N));
    std::vector<std::vector<int>> elem_nodes;
    for (const ElementBlock& b : reference.blocks)
      for (Eigen::Index r = 0; r < b.conn.rows(); ++r) {
        std::vector<int> en(b.conn.row(r).data(), b.conn.row(r).data() + b.conn.cols());
        for (int u : en)
          for (int v : en)
            if (u != v) nbr[static_cast<std::size_t>(u)].push_back(v);
        elem_nodes.push_back(std::move(en));
      }
    for (int round = 0; round < 8; ++round) {
      std::vector<int> bad_nodes;
      for (std::size_t e2 = 0; e2 < out.after.size(); ++e2)
        if (out.after[e2].inverted && !out.before[e2].inverted)
          bad_nodes.insert(bad_nodes.end(), elem_nodes[e2].begin(), elem_nodes[e2].end());
      if (bad_nodes.empty()) break;
      std::sort(bad_nodes.begin(), bad_nodes.end());
      bad_nodes.erase(std::unique(bad_nodes.begin(), bad_nodes.end()), bad_nodes.end());
      for (int i : bad_nodes) {
        Eigen::Vector3d c = Eigen::Vector3d::Zero();
        for (int v : nbr[static_cast<std::size_t>(i)]) c += out.mesh.nodes.row(v).transpose();
        if (nbr[static_cast<std::size_t>(i)].empty()) continue;
        c /= static_cast<double>(nbr[static_cast<std::size_t>(i)].size());
        Eigen::Vector3d q;
        if (foot(c, mapped_n.row(i).transpose(), q)) {
          out.mesh.nodes.row(i) = q.transpose();
          on_surface[static_cast<std::size_t>(i)] = 1;
        }
      }
      out.after = element_quality(out.mesh, &n1);
    }
  }
  for (Eigen::Index i = 0; i < N; ++i) {
    if (on_surface[static_cast<std::size_t>(i)]) {
      ++out.projected;
      out.max_projection_distance = std::max(out.max_projection_distance, (out.mesh.nodes.row(i) - mapped.row(i)).norm());
    } else {
      ++out.unprojected;
    }
  }
  // How far the final nodes are from the target triangles (0 for the projected ones, up to the
  // triangulation's rounding; the unprojected ones tell how far the feature is off the surface).
  for (Eigen::Index i = 0; i < N; ++i) {
    const Eigen::Vector3d y = out.mesh.nodes.row(i);
    double best = INFINITY;
    for (std::size_t r = 0; r < region.size(); ++r)
      best = std::min(best, (closest_point_on_triangle(y, corner(r, 0), corner(r, 1), corner(r, 2)) - y).norm());
    out.max_surface_distance = std::max(out.max_surface_distance, best);
  }

  out.before_summary = summarize(out.before);
  out.after_summary = summarize(out.after);
  std::vector<int> invalid;
  e = 0;
  for (const ElementBlock& b : out.mesh.blocks)
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r, ++e)
      if (out.after[static_cast<std::size_t>(e)].inverted && !out.before[static_cast<std::size_t>(e)].inverted) {
        invalid.push_back(static_cast<int>(e));
        out.invalid_elements.push_back(b.ids.empty() ? static_cast<long>(e + 1) : b.ids[static_cast<std::size_t>(r)]);
      }
  if (!invalid.empty()) out.mesh.element_sets["FE_INVALID"] = invalid;

  // The specification travels with the mesh: its axis mapped, the transform recorded.
  nlohmann::ordered_json spec;
  try {
    spec = nlohmann::ordered_json::parse(spec_json);
  } catch (const std::exception&) {
    spec = nlohmann::ordered_json::object();
  }
  if (!spec.is_object()) spec = nlohmann::ordered_json::object();
  if (spec.contains("axis") && spec["axis"].is_object() && spec["axis"].contains("point") && spec["axis"].contains("direction")) {
    try {
      const auto p = spec["axis"]["point"].get<std::vector<double>>();
      const auto d = spec["axis"]["direction"].get<std::vector<double>>();
      if (p.size() == 3 && d.size() == 3) {
        const Eigen::Vector3d P(p[0], p[1], p[2]), D(d[0], d[1], d[2]);
        const Eigen::Vector3d P1 = apply_transform(H, P), D1 = (transform_jacobian(H, P) * D).normalized();
        spec["axis"]["point"] = {P1.x(), P1.y(), P1.z()};
        spec["axis"]["direction"] = {D1.x(), D1.y(), D1.z()};
      }
    } catch (const std::exception&) {
      // a malformed axis is carried unchanged
    }
  }
  nlohmann::ordered_json h = nlohmann::ordered_json::array();
  for (int r = 0; r < 4; ++r) h.push_back({H(r, 0), H(r, 1), H(r, 2), H(r, 3)});
  spec["transform"] = h;
  out.spec_json = spec.dump(1, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
  return out;
}

}  // namespace fe
