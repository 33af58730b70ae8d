// Shared test helpers.
#pragma once

#include "featureextract/mesh.h"
#include "featureextract/result.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <Eigen/Core>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>
#include <vector>

namespace fe_test {

// The generated models' folder: FE_MODELS (set by CTest), else ./models.
inline std::string models() {
  const char* d = std::getenv("FE_MODELS");
  return d ? d : "models";
}

// The generator's ground truth (models()/truth.json).
inline nlohmann::json truth() {
  std::ifstream in(models() + "/truth.json");
  EXPECT_TRUE(in.good()) << "run fe_make_models first";
  return nlohmann::json::parse(in);
}

// An n x n grid of vertices point(i, j) (row i n + j), two triangles per cell, no B-rep faces.
template <class Point>
inline fe::TriangleMesh grid_mesh(int n, Point point) {
  fe::TriangleMesh s;
  s.vertices.resize(n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) s.vertices.row(i * n + j) = point(i, j).transpose();
  s.triangles.resize(2 * (n - 1) * (n - 1), 3);
  int t = 0;
  for (int i = 0; i + 1 < n; ++i)
    for (int j = 0; j + 1 < n; ++j) {
      s.triangles.row(t++) << i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1;
      s.triangles.row(t++) << i * n + j, (i + 1) * n + j + 1, i * n + j + 1;
    }
  s.face_ids = Eigen::VectorXi::Zero(t);
  return s;
}

// Index of the match whose center is within `tol` (in x and y) of (x, y), or -1.
inline int match_near(const fe::Result& r, double x, double y, double tol) {
  for (std::size_t i = 0; i < r.matches.size(); ++i)
    if (std::abs(r.matches[i].center.x() - x) < tol && std::abs(r.matches[i].center.y() - y) < tol) return static_cast<int>(i);
  return -1;
}

// The triangles of `m` clipped to the box lo..hi, as a user clips a region out of an STL (no caps:
// an open region; a triangle soup without B-rep faces, like an STL file).
inline fe::TriangleMesh clip_to_box(const fe::TriangleMesh& m, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi) {
  std::vector<Eigen::Vector3d> out;
  for (Eigen::Index t = 0; t < m.triangles.rows(); ++t) {
    std::vector<Eigen::Vector3d> poly;
    for (int k = 0; k < 3; ++k) poly.push_back(m.vertices.row(m.triangles(t, k)).transpose());
    for (int axis = 0; axis < 3 && !poly.empty(); ++axis)
      for (int side = 0; side < 2 && !poly.empty(); ++side) {  // Sutherland-Hodgman, one box plane at a time
        const double w = side ? hi(axis) : lo(axis);
        auto inside = [&](const Eigen::Vector3d& v) { return side ? v(axis) <= w : v(axis) >= w; };
        std::vector<Eigen::Vector3d> next;
        for (std::size_t k = 0; k < poly.size(); ++k) {
          const Eigen::Vector3d& p = poly[k];
          const Eigen::Vector3d& q = poly[(k + 1) % poly.size()];
          if (inside(p)) next.push_back(p);
          if (inside(p) != inside(q)) next.push_back(p + (w - p(axis)) / (q(axis) - p(axis)) * (q - p));
        }
        poly.swap(next);
      }
    for (std::size_t k = 1; k + 1 < poly.size(); ++k) {
      out.push_back(poly[0]);
      out.push_back(poly[k]);
      out.push_back(poly[k + 1]);
    }
  }
  fe::TriangleMesh r;
  r.vertices.resize(static_cast<Eigen::Index>(out.size()), 3);
  r.triangles.resize(static_cast<Eigen::Index>(out.size() / 3), 3);
  for (std::size_t i = 0; i < out.size(); ++i) {
    r.vertices.row(static_cast<Eigen::Index>(i)) = out[i].transpose();
    r.triangles(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)) = static_cast<int>(i);
  }
  r.face_ids = Eigen::VectorXi::Zero(r.triangles.rows());
  r.source = "clipped region";
  return r;
}

// Expects read(path) to throw InputError whose message starts with "PATH: ", is one line and
// contains `fragment`.
template <class Read>
void expect_one_line_error(const std::string& path, const std::string& fragment, Read read) {
  try {
    read(path);
    FAIL() << "no error for " << path;
  } catch (const fe::InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << msg;
  }
}

}  // namespace fe_test
