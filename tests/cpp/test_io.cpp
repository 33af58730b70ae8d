// Input: readers, bad input (one-line messages naming the file), orientation repair, parameters.
#include "featureextract/io.h"
#include "featureextract/params.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>

namespace {

std::string tmp(const std::string& name) { return ::testing::TempDir() + "fe_io_" + name; }

void write(const std::string& path, const std::string& data) { std::ofstream(path, std::ios::binary) << data; }

fe::TriangleMesh square() {
  fe::TriangleMesh m;
  m.vertices.resize(4, 3);
  m.vertices << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0;
  m.triangles.resize(2, 3);
  m.triangles << 0, 1, 2, 0, 2, 3;
  m.face_ids = Eigen::VectorXi::Zero(2);
  return m;
}

void expect_input_error(const std::string& path, const std::string& fragment) {
  fe_test::expect_one_line_error(path, fragment, [](const std::string& p) { return fe::read_shape(p); });
}

}  // namespace

TEST(Io, StlBinaryAndAsciiRoundTrip) {
  const fe::TriangleMesh m = square();
  for (bool binary : {true, false}) {
    const std::string p = tmp(binary ? "b.stl" : "a.stl");
    fe::write_stl(m, p, binary);
    const fe::TriangleMesh r = fe::read_shape(p);
    EXPECT_EQ(r.triangles.rows(), 2);
    EXPECT_NEAR(r.diagonal(), std::sqrt(2.0), 1e-6);
    EXPECT_FALSE(r.from_brep());
  }
}

TEST(Io, ObjAndPly) {
  write(tmp("q.obj"), "# quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1 2/2 3/3 4/4\n");
  EXPECT_EQ(fe::read_shape(tmp("q.obj")).triangles.rows(), 2);
  write(tmp("q.ply"), "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                      "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  EXPECT_EQ(fe::read_shape(tmp("q.ply")).triangles.rows(), 1);
}

TEST(Io, BadInputGetsOneLineNamingTheFile) {
  expect_input_error(tmp("missing.stl"), "cannot open");
  write(tmp("empty.stl"), "");
  expect_input_error(tmp("empty.stl"), "empty");
  write(tmp("empty.step"), "");
  expect_input_error(tmp("empty.step"), "empty");
  // truncated binary STL: header says 10 triangles, data holds 1
  std::string bin(84 + 50, '\0');
  bin[80] = 10;
  write(tmp("trunc.stl"), bin);
  expect_input_error(tmp("trunc.stl"), "truncated");
  std::string garbage;
  for (int i = 0; i < 5000; ++i) garbage.push_back(static_cast<char>((i * 7919) % 251));
  write(tmp("garbage.stl"), garbage);
  expect_input_error(tmp("garbage.stl"), "not an STL");
  write(tmp("garbage.step"), garbage);
  expect_input_error(tmp("garbage.step"), "STEP");
  write(tmp("garbage.brep"), garbage);
  expect_input_error(tmp("garbage.brep"), "BREP");
  write(tmp("garbage.ply"), garbage);
  expect_input_error(tmp("garbage.ply"), "PLY");
  write(tmp("nan.stl"), "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex nan 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid x\n");
  expect_input_error(tmp("nan.stl"), "non-finite");
  write(tmp("inf.obj"), "v 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n");
  expect_input_error(tmp("inf.obj"), "non-finite");
  write(tmp("zero.stl"), "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 1 1\nvertex 2 2 2\nendloop\nendfacet\nendsolid x\n");
  expect_input_error(tmp("zero.stl"), "zero area");
  write(tmp("bad.xyz"), "1 2 3\n");
  expect_input_error(tmp("bad.xyz"), "unknown file type");
  write(tmp("range.obj"), "v 0 0 0\nv 1 0 0\nf 1 2 9\n");
  expect_input_error(tmp("range.obj"), "out of range");
}

TEST(Io, ZeroAreaTrianglesAreDroppedAndCounted) {
  fe::TriangleMesh m = square();
  m.triangles.conservativeResize(3, 3);
  m.triangles.row(2) << 0, 0, 1;  // degenerate
  m.source = "mem";
  fe::validate_mesh(m);
  EXPECT_EQ(m.triangles.rows(), 2);
  EXPECT_EQ(m.dropped_degenerate, 1u);
}

TEST(Io, InconsistentOrientationIsRepairedByMajority) {
  // a 3 x 1 strip of 6 triangles, all +z, with two flipped
  fe::TriangleMesh m;
  m.vertices.resize(8, 3);
  m.vertices << 0, 0, 0, 1, 0, 0, 2, 0, 0, 3, 0, 0, 0, 1, 0, 1, 1, 0, 2, 1, 0, 3, 1, 0;
  m.triangles.resize(6, 3);
  m.triangles << 0, 1, 5, 0, 5, 4, 1, 2, 6, 1, 6, 5, 2, 3, 7, 2, 7, 6;
  std::swap(m.triangles(1, 1), m.triangles(1, 2));
  std::swap(m.triangles(4, 1), m.triangles(4, 2));
  m.face_ids = Eigen::VectorXi::Zero(6);
  EXPECT_EQ(fe::orient_consistently(m), 2u);
  for (Eigen::Index t = 0; t < 6; ++t) {
    const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)), b = m.vertices.row(m.triangles(t, 1)), c = m.vertices.row(m.triangles(t, 2));
    EXPECT_GT((b - a).cross(c - a).z(), 0) << "triangle " << t;
  }
}

TEST(Params, JsonRoundTripAndErrors) {
  fe::Params p;
  p.seed = 42;
  p.scale_max = 2.0;
  p.allow_reflection = true;
  const fe::Params q = fe::params_from_json(fe::params_to_json(p));
  EXPECT_EQ(q.seed, 42u);
  EXPECT_EQ(q.scale_max, 2.0);
  EXPECT_TRUE(q.allow_reflection);
  EXPECT_THROW(fe::params_from_json("{\"no_such\": 1}"), std::invalid_argument);
  EXPECT_THROW(fe::params_from_json("{\"si_band\": 0.9}"), std::invalid_argument);
  EXPECT_THROW(fe::params_from_json("{\"shot_radii\": 2.5}"), std::invalid_argument);
  EXPECT_THROW(fe::params_from_json("{\"allow_reflection\": 1}"), std::invalid_argument);
  EXPECT_THROW(fe::params_from_json("[1, 2]"), std::invalid_argument);
  EXPECT_THROW(fe::params_from_json("{\"scale_min\": 0.9, \"scale_max\": 1.0, \"axis_scale_min\": 2, \"axis_scale_max\": 1}"), std::invalid_argument);
  // every parameter is documented and belongs to one step, listed together (the panel's groups)
  std::vector<std::string> groups;
  for (const auto& info : fe::param_table()) {
    EXPECT_FALSE(info.help.empty()) << info.name;
    EXPECT_FALSE(info.default_value.empty()) << info.name;
    EXPECT_FALSE(info.group.empty()) << info.name;
    if (groups.empty() || groups.back() != info.group) groups.push_back(info.group);
  }
  const std::vector<std::string> steps = {"1. Sampling", "2. Shape index and SHOT", "3. Key points", "4. Pairs and clusters",
                                          "5. RANSAC and refinement", "6. Acceptance", "Reference", "Result", "Run"};
  EXPECT_EQ(groups, steps);
}
