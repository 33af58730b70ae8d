// Element normals and shape quality (see element_quality in featureextract/femesh.h).
#include "featureextract/femesh.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

namespace fe {

using Vec3 = Eigen::Vector3d;

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

ElementQuality tet_quality(const std::array<Vec3, 10>& x) {
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

ElementQuality hex_quality(const std::array<Vec3, 10>& x) {
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

// Jacobian determinant of the quadratic tetrahedron (Abaqus node order) at barycentric point L.
double tet10_det(const std::array<Vec3, 10>& x, const std::array<double, 4>& L) {
  static const int mid[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  std::array<Vec3, 4> G;  // d x / d L_j
  for (int j = 0; j < 4; ++j) G[static_cast<std::size_t>(j)] = (4 * L[static_cast<std::size_t>(j)] - 1) * x[static_cast<std::size_t>(j)];
  for (int e = 0; e < 6; ++e) {
    const int a = mid[e][0], b = mid[e][1];
    G[static_cast<std::size_t>(a)] += 4 * L[static_cast<std::size_t>(b)] * x[static_cast<std::size_t>(4 + e)];
    G[static_cast<std::size_t>(b)] += 4 * L[static_cast<std::size_t>(a)] * x[static_cast<std::size_t>(4 + e)];
  }
  return (G[1] - G[0]).cross(G[2] - G[0]).dot(G[3] - G[0]);
}

// The corner tetrahedron's quality, its scaled Jacobian times the smallest ratio of the quadratic
// map's Jacobian at the ten nodes to the straight one's (femesh.h).
ElementQuality tet10_quality(const std::array<Vec3, 10>& x) {
  ElementQuality q = tet_quality(x);
  const double straight = (x[1] - x[0]).cross(x[2] - x[0]).dot(x[3] - x[0]);
  if (!(straight > 0)) return q;
  static const double at[10][4] = {{1, 0, 0, 0},     {0, 1, 0, 0},     {0, 0, 1, 0},     {0, 0, 0, 1},     {.5, .5, 0, 0},
                                   {0, .5, .5, 0},   {.5, 0, .5, 0},   {.5, 0, 0, .5},   {0, .5, 0, .5},   {0, 0, .5, .5}};
  double ratio = kInf;
  for (const auto& l : at) ratio = std::min(ratio, tet10_det(x, {l[0], l[1], l[2], l[3]}) / straight);
  q.scaled_jacobian *= std::min(1.0, ratio);
  q.inverted = ratio <= 0;
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
      std::array<Vec3, 10> x;
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
        case ElementType::Tet10: out.push_back(tet10_quality(x)); break;
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
