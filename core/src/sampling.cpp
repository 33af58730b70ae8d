// Step 1 (paper 3.3): area-weighted random samples on the triangles, thinned to one point per cube
// of side `spacing` so that the density is uniform whatever the tessellation (cracked, unwelded or
// jittered meshes sample like clean ones).
#include "featureextract/geometry.h"
#include "description.h"  // mesh_area

#include <Eigen/Geometry>  // .cross()
#include <cmath>
#include <random>
#include <unordered_map>

namespace fe {

Samples sample_surface(const TriangleMesh& mesh, double spacing, std::uint64_t seed) {
  if (!(spacing > 0)) throw std::invalid_argument("sample_surface: spacing must be > 0");
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  const double oversample = 4.0;  // candidates per spacing^2 of area before thinning
  const double inv = 1.0 / spacing;
  const Eigen::Vector3d origin = mesh.vertices.colwise().minCoeff();

  struct Cell { Eigen::Vector3d p, n; int tri; double d2; };
  std::unordered_map<std::uint64_t, std::size_t> cell_of;
  std::vector<Cell> cells;
  {  // room for the cells a surface of this area meets, so that the map does not grow by rehashing
    const double expect = 1.5 * mesh_area(mesh) * inv * inv;
    if (std::isfinite(expect) && expect < 5e7) {
      cell_of.reserve(static_cast<std::size_t>(expect));
      cells.reserve(static_cast<std::size_t>(expect));
    }
  }
  auto key = [&](const Eigen::Vector3d& p, Eigen::Vector3d& center) {
    const Eigen::Vector3d g = (p - origin) * inv;
    // through a signed integer: a sample a rounding error below the origin is in cell -1, and a
    // negative double cast straight to an unsigned type is undefined (UBSan, fuzz_extract)
    const auto cell = [](double v) { return static_cast<std::uint64_t>(static_cast<std::int64_t>(std::floor(v))) & 0x1FFFFF; };
    const std::uint64_t ix = cell(g.x()), iy = cell(g.y()), iz = cell(g.z());
    center = origin + spacing * Eigen::Vector3d(std::floor(g.x()) + 0.5, std::floor(g.y()) + 0.5, std::floor(g.z()) + 0.5);
    return (ix << 42) | (iy << 21) | iz;
  };
  for (Eigen::Index t = 0; t < mesh.triangles.rows(); ++t) {
    const Eigen::Vector3d a = mesh.vertices.row(mesh.triangles(t, 0)), b = mesh.vertices.row(mesh.triangles(t, 1)),
                          c = mesh.vertices.row(mesh.triangles(t, 2));
    Eigen::Vector3d n = (b - a).cross(c - a);
    const double area = 0.5 * n.norm();
    if (!(area > 0)) continue;
    n.normalize();
    const double expected = area * inv * inv * oversample;
    std::size_t count = static_cast<std::size_t>(expected);
    if (uni(rng) < expected - static_cast<double>(count)) ++count;
    for (std::size_t s = 0; s < count; ++s) {
      double r1 = std::sqrt(uni(rng)), r2 = uni(rng);
      const Eigen::Vector3d p = (1 - r1) * a + r1 * (1 - r2) * b + r1 * r2 * c;
      Eigen::Vector3d center;
      const std::uint64_t k = key(p, center);
      const double d2 = (p - center).squaredNorm();
      auto it = cell_of.find(k);
      if (it == cell_of.end()) {
        cell_of.emplace(k, cells.size());
        cells.push_back({p, n, static_cast<int>(t), d2});
      } else if (d2 < cells[it->second].d2) {
        cells[it->second] = {p, n, static_cast<int>(t), d2};
      }
    }
  }
  Samples s;
  const Eigen::Index N = static_cast<Eigen::Index>(cells.size());
  s.points.resize(N, 3);
  s.normals.resize(N, 3);
  s.face_ids.resize(N);
  s.triangle_ids.resize(N);
  for (Eigen::Index i = 0; i < N; ++i) {
    const Cell& c = cells[static_cast<std::size_t>(i)];
    s.points.row(i) = c.p;
    s.normals.row(i) = c.n;
    s.triangle_ids(i) = c.tri;
    s.face_ids(i) = mesh.face_ids.size() ? mesh.face_ids(c.tri) : 0;
  }
  return s;
}

}  // namespace fe
