// FE meshes: .inp / .msh reading and writing (round trips, hand-written gmsh 2.2 and 4.1, bad input)
// and element quality (aspect ratio, scaled Jacobian, angles, inversion against reference normals).
#include "featureextract/femesh.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <algorithm>

namespace {

std::string tmp(const std::string& name) { return ::testing::TempDir() + "fe_femesh_" + name; }

void write(const std::string& path, const std::string& data) { std::ofstream(path, std::ios::binary) << data; }

void expect_input_error(const std::string& path, const std::string& fragment) {
  fe_test::expect_one_line_error(path, fragment, [](const std::string& p) { return fe::read_fe_mesh(p); });
}

// Comments, mixed case, unknown keywords, ids with gaps, a continued element record, GENERATE,
// set names inside *ELSET data, shells and a solid.
const char* kInp = R"(*Heading
 test mesh for FeatureExtract
** a comment line
*node, nset=NALL
10, 0, 0, 0
11, 1., 0., 0.
12, 1, 1, 0
13, 0, 1, 0
20, 2.0E+00, 0, 0
21, 2, 1, 0
30, 0, 0, 1
31, 1, 0, 1
32, 1, 1, 1
33, 0, 1, 1
*Element, type=S4R, elset=Plate
100, 10, 11,
12, 13
101, 11, 20, 21, 12
*ELEMENT, TYPE=S3
205, 20, 21, 12
*element, type=C3D8, ELSET=Solid
300, 10, 11, 12, 13, 30, 31, 32, 33
*Nset, nset=Edge, generate
10, 13, 3
*NSET, NSET=Top
30, 31,
32, 33
*Elset, elset=All
Plate, 205, solid
*Elset, elset=Gen, GENERATE
100, 101
*Material, name=Steel
*Elastic
210000, 0.3
*Step
*Static
*End Step
)";

// Comparable, id-based view of a mesh: element order and block grouping may differ between formats.
struct Canon {
  std::map<long, std::array<double, 3>> nodes;
  std::map<long, std::pair<int, std::vector<long>>> elements;
  std::map<std::string, std::set<long>> node_sets, element_sets;
  bool operator==(const Canon& o) const {
    return nodes == o.nodes && elements == o.elements && node_sets == o.node_sets && element_sets == o.element_sets;
  }
};

Canon canon(const fe::FeMesh& m) {
  Canon c;
  for (Eigen::Index i = 0; i < m.nodes.rows(); ++i) c.nodes[m.node_ids[i]] = {m.nodes(i, 0), m.nodes(i, 1), m.nodes(i, 2)};
  std::vector<long> eids;
  for (const auto& b : m.blocks)
    for (Eigen::Index r = 0; r < b.conn.rows(); ++r) {
      std::vector<long> nodes;
      for (Eigen::Index j = 0; j < b.conn.cols(); ++j) nodes.push_back(m.node_ids[b.conn(r, j)]);
      c.elements[b.ids[r]] = {static_cast<int>(b.type), nodes};
      eids.push_back(b.ids[r]);
    }
  for (const auto& [name, v] : m.node_sets)
    for (int i : v) c.node_sets[name].insert(m.node_ids[i]);
  for (const auto& [name, v] : m.element_sets) {
    c.element_sets[name];
    for (int i : v) c.element_sets[name].insert(eids[i]);
  }
  for (const auto& [name, v] : m.node_sets) c.node_sets[name];
  return c;
}

fe::FeMesh single(fe::ElementType type, const std::vector<std::array<double, 3>>& pts) {
  fe::FeMesh m;
  m.nodes.resize(static_cast<Eigen::Index>(pts.size()), 3);
  for (std::size_t i = 0; i < pts.size(); ++i) {
    m.nodes.row(static_cast<Eigen::Index>(i)) << pts[i][0], pts[i][1], pts[i][2];
    m.node_ids.push_back(static_cast<long>(i) + 1);
  }
  fe::ElementBlock b;
  b.type = type;
  b.ids = {1};
  b.conn.resize(1, static_cast<Eigen::Index>(pts.size()));
  for (std::size_t i = 0; i < pts.size(); ++i) b.conn(0, static_cast<Eigen::Index>(i)) = static_cast<int>(i);
  m.blocks.push_back(b);
  return m;
}

}  // namespace

TEST(FeMesh, ReadsAbaqusInput) {
  write(tmp("a.inp"), kInp);
  const fe::FeMesh m = fe::read_fe_mesh(tmp("a.inp"));
  ASSERT_EQ(m.nodes.rows(), 10);
  EXPECT_EQ(m.node_ids[4], 20);
  EXPECT_EQ(m.nodes(4, 0), 2.0);
  ASSERT_EQ(m.blocks.size(), 3u);
  EXPECT_EQ(m.num_elements(), 4u);
  EXPECT_EQ(m.blocks[0].type, fe::ElementType::Quad4);
  EXPECT_EQ(m.blocks[0].elset, "Plate");
  EXPECT_EQ(m.blocks[0].ids, (std::vector<long>{100, 101}));
  EXPECT_EQ(m.blocks[0].conn.row(0), (Eigen::RowVector4i(0, 1, 2, 3)));  // continued record
  EXPECT_EQ(m.blocks[1].type, fe::ElementType::Tri3);
  EXPECT_EQ(m.blocks[1].elset, "");
  EXPECT_EQ(m.blocks[2].type, fe::ElementType::Hex8);
  EXPECT_EQ(m.blocks[2].conn(0, 7), 9);
  EXPECT_EQ(m.node_sets.at("NALL").size(), 10u);
  EXPECT_EQ(m.node_sets.at("Edge"), (std::vector<int>{0, 3}));
  EXPECT_EQ(m.node_sets.at("Top"), (std::vector<int>{6, 7, 8, 9}));
  EXPECT_EQ(m.element_sets.at("Plate"), (std::vector<int>{0, 1}));
  EXPECT_EQ(m.element_sets.at("Solid"), (std::vector<int>{3}));
  EXPECT_EQ(m.element_sets.at("All"), (std::vector<int>{0, 1, 2, 3}));  // "solid" matches "Solid"
  EXPECT_EQ(m.element_sets.at("Gen"), (std::vector<int>{0, 1}));
  EXPECT_EQ(m.element_sets.size(), 4u);
}

TEST(FeMesh, InpAndMshRoundTrips) {
  write(tmp("rt.inp"), kInp);
  const fe::FeMesh m = fe::read_fe_mesh(tmp("rt.inp"));
  fe::write_inp(m, tmp("rt_out.inp"));
  const fe::FeMesh a = fe::read_fe_mesh(tmp("rt_out.inp"));
  EXPECT_TRUE(canon(a) == canon(m));
  ASSERT_EQ(a.blocks.size(), m.blocks.size());
  for (std::size_t i = 0; i < a.blocks.size(); ++i) {
    EXPECT_EQ(a.blocks[i].elset, m.blocks[i].elset);
    EXPECT_EQ(a.blocks[i].conn, m.blocks[i].conn);
  }
  EXPECT_EQ(a.nodes, m.nodes);  // exact: shortest round-trip formatting

  fe::write_msh(m, tmp("rt.msh"));
  const fe::FeMesh b = fe::read_fe_mesh(tmp("rt.msh"));
  EXPECT_TRUE(canon(b) == canon(m));
  EXPECT_EQ(b.nodes, m.nodes);
  // a block's elset is its elements' first physical group: the S3 element, in no block elset but in "All", gets "All"
  std::set<std::string> elsets;
  for (const auto& blk : b.blocks) elsets.insert(blk.elset);
  EXPECT_EQ(elsets, (std::set<std::string>{"Plate", "All", "Solid"}));
  // and back to .inp
  fe::write_inp(b, tmp("rt2.inp"));
  EXPECT_TRUE(canon(fe::read_fe_mesh(tmp("rt2.inp"))) == canon(m));

  // a mesh built in memory: no ids, empty sets, names needing quotes
  fe::FeMesh c = single(fe::ElementType::Tri3, {{{0, 0, 0}}, {{1, 0, 0}}, {{0, 1, 0}}});
  c.node_ids.clear();
  c.blocks[0].ids.clear();
  c.blocks[0].elset = "my shell";
  c.node_sets["empty"] = {};
  c.element_sets["none"] = {};
  for (const char* ext : {"inp", "msh"}) {
    const std::string p = tmp(std::string("mem.") + ext);
    if (std::string(ext) == "inp") fe::write_inp(c, p);
    else fe::write_msh(c, p);
    const fe::FeMesh r = fe::read_fe_mesh(p);
    EXPECT_EQ(r.node_ids, (std::vector<long>{1, 2, 3})) << ext;
    ASSERT_EQ(r.blocks.size(), 1u) << ext;
    EXPECT_EQ(r.blocks[0].elset, "my shell") << ext;
    EXPECT_EQ(r.element_sets.at("my shell"), std::vector<int>{0}) << ext;
    EXPECT_TRUE(r.node_sets.count("empty")) << ext;
    EXPECT_TRUE(r.element_sets.count("none")) << ext;
  }
}

TEST(FeMesh, ReadsGmsh22) {
  write(tmp("v2.msh"), R"($MeshFormat
2.2 0 8
$EndMeshFormat
$PhysicalNames
3
2 1 "skin"
0 2 "fixed"
2 3 "also"
$EndPhysicalNames
$Nodes
5
1 0 0 0
2 1 0 0
3 1 1 0
4 0 1 0
7 0 0 1
$EndNodes
$Elements
6
1 15 2 2 1 1
2 1 2 0 1 1 2
3 3 2 1 1 1 2 3 4
4 2 2 1 1 2 3 4
5 4 2 0 1 1 2 4 7
6 2 2 3 1 2 3 4
$EndElements
$NodeData
1
"temperature"
$EndNodeData
)");
  const fe::FeMesh m = fe::read_fe_mesh(tmp("v2.msh"));
  ASSERT_EQ(m.nodes.rows(), 5);
  EXPECT_EQ(m.node_ids.back(), 7);
  ASSERT_EQ(m.blocks.size(), 3u);
  EXPECT_EQ(m.blocks[0].type, fe::ElementType::Quad4);
  EXPECT_EQ(m.blocks[0].elset, "skin");
  EXPECT_EQ(m.blocks[1].type, fe::ElementType::Tri3);
  EXPECT_EQ(m.blocks[1].ids, std::vector<long>{4});
  EXPECT_EQ(m.blocks[2].type, fe::ElementType::Tet4);
  EXPECT_EQ(m.blocks[2].elset, "");
  EXPECT_EQ(m.blocks[2].conn.row(0), (Eigen::RowVector4i(0, 1, 3, 4)));
  EXPECT_EQ(m.element_sets.at("skin"), (std::vector<int>{0, 1}));
  EXPECT_EQ(m.node_sets.at("fixed"), std::vector<int>{0});
  EXPECT_EQ(m.element_sets.at("also"), std::vector<int>{1});  // element 6 is element 4 written again for "also"
  EXPECT_EQ(m.element_sets.size(), 2u);
  EXPECT_EQ(m.num_elements(), 3u);
}

const char* kMsh41 = R"($MeshFormat
4.1 0 8
$EndMeshFormat
$PhysicalNames
1
2 5 "top face"
$EndPhysicalNames
$Entities
1 0 1 1
1 0 0 0 0
1 0 0 0 1 1 0 1 5 0
1 0 0 0 1 1 1 0 0
$EndEntities
$Nodes
3 9 1 9
0 1 0 1
1
0 0 0
2 1 1 4
2
3
4
5
1 0 0 0.1 0.2
1 1 0 0.3 0.4
0 1 0 0.5 0.6
0.5 0.5 0 0.7 0.8
3 1 0 4
6
7
8
9
0 0 1
1 0 1
1 1 1
0 1 1
$EndNodes
$Elements
3 3 1 10
0 1 15 1
1 1
2 1 3 1
2 1 2 3 4
3 1 5 1
10 1 2 3 4 6 7 8 9
$EndElements
)";

TEST(FeMesh, ReadsGmsh41) {
  write(tmp("v4.msh"), kMsh41);
  const fe::FeMesh m = fe::read_fe_mesh(tmp("v4.msh"));
  ASSERT_EQ(m.nodes.rows(), 9);
  EXPECT_EQ(m.nodes.row(4), Eigen::RowVector3d(0.5, 0.5, 0));  // parametric u, v skipped
  ASSERT_EQ(m.blocks.size(), 2u);
  EXPECT_EQ(m.blocks[0].type, fe::ElementType::Quad4);
  EXPECT_EQ(m.blocks[0].elset, "top face");
  EXPECT_EQ(m.blocks[1].type, fe::ElementType::Hex8);
  EXPECT_EQ(m.blocks[1].ids, std::vector<long>{10});
  EXPECT_EQ(m.element_sets.at("top face"), std::vector<int>{0});
  EXPECT_TRUE(m.node_sets.empty());  // the point element has no physical group
  const auto q = fe::element_quality(m);
  EXPECT_NEAR(q[1].scaled_jacobian, 1, 1e-12);
  EXPECT_NEAR(q[1].aspect_ratio, 1, 1e-12);
  EXPECT_NEAR(q[1].min_angle_deg, 90, 1e-9);
}

TEST(FeMesh, BadInputGetsOneLineNamingTheFile) {
  expect_input_error(tmp("missing.inp"), "cannot open");
  write(tmp("empty.inp"), "\n\n");
  expect_input_error(tmp("empty.inp"), "empty");
  write(tmp("x.vtk"), "# vtk\n");
  expect_input_error(tmp("x.vtk"), "unknown FE mesh file type");
  const std::string nodes = "*NODE\n1, 0, 0, 0\n2, 1, 0, 0\n3, 0, 1, 0\n";
  write(tmp("trunc.inp"), nodes + "*ELEMENT, TYPE=S3\n1, 1, 2");
  expect_input_error(tmp("trunc.inp"), "incomplete");
  write(tmp("type.inp"), nodes + "*ELEMENT, TYPE=C3D20\n1, 1, 2, 3\n");
  expect_input_error(tmp("type.inp"), "C3D20");
  write(tmp("missing_node.inp"), nodes + "*ELEMENT, TYPE=S3\n1, 1, 2, 99\n");
  expect_input_error(tmp("missing_node.inp"), "line 6: element 1 refers to missing node 99");
  write(tmp("missing_elem.inp"), nodes + "*ELEMENT, TYPE=S3\n1, 1, 2, 3\n*ELSET, ELSET=E\n1, 2\n");
  expect_input_error(tmp("missing_elem.inp"), "missing element 2");
  write(tmp("dup.inp"), nodes + "2, 5, 5, 5\n");
  expect_input_error(tmp("dup.inp"), "duplicate node id 2");
  write(tmp("badnum.inp"), "*NODE\n1, 0, zero, 0\n");
  expect_input_error(tmp("badnum.inp"), "line 2: malformed coordinate");
  write(tmp("nan.inp"), "*NODE\n1, 0, nan, 0\n");
  expect_input_error(tmp("nan.inp"), "non-finite");
  write(tmp("nonodes.inp"), "*HEADING\nnothing\n");
  expect_input_error(tmp("nonodes.inp"), "no nodes");
  std::string garbage;
  for (int i = 0; i < 5000; ++i) garbage.push_back(static_cast<char>((i * 7919) % 251));
  write(tmp("garbage.inp"), garbage);
  expect_input_error(tmp("garbage.inp"), "not an Abaqus/CalculiX input file");
  write(tmp("garbage.msh"), garbage);
  expect_input_error(tmp("garbage.msh"), "not a gmsh .msh file");

  const std::string msh = kMsh41;
  write(tmp("trunc.msh"), msh.substr(0, msh.find("10 1 2 3 4 6")));
  expect_input_error(tmp("trunc.msh"), "unexpected end of file");
  std::string hex20 = msh;
  hex20.replace(hex20.find("3 1 5 1"), 7, "3 1 17 1");
  write(tmp("hex20.msh"), hex20);
  expect_input_error(tmp("hex20.msh"), "unsupported gmsh element type 17 (20-node hexahedron)");
  std::string v40 = msh;
  v40.replace(v40.find("4.1 0 8"), 7, "4.0 0 8");
  write(tmp("v40.msh"), v40);
  expect_input_error(tmp("v40.msh"), "version 4.0");
  std::string binary = msh;
  binary.replace(binary.find("4.1 0 8"), 7, "4.1 1 8");
  write(tmp("bin.msh"), binary);
  expect_input_error(tmp("bin.msh"), "binary");
  std::string missing = msh;
  missing.replace(missing.find("10 1 2 3 4 6 7 8 9"), 18, "10 1 2 3 4 6 7 8 99");
  write(tmp("missing_node.msh"), missing);
  expect_input_error(tmp("missing_node.msh"), "refers to missing node 99");

  // every truncation of valid files either reads or gives InputError, never anything else
  for (const std::string& text : {std::string(kInp), msh}) {
    const std::string ext = text == msh ? "msh" : "inp";
    for (std::size_t n = 0; n < text.size(); ++n) {
      const std::string p = tmp("cut." + ext);
      write(p, text.substr(0, n));
      try {
        fe::read_fe_mesh(p);
      } catch (const fe::InputError&) {
      }
    }
  }
}

TEST(FeMeshQuality, PerfectElements) {
  const double h = std::sqrt(3.0) / 2;
  const auto tri = fe::element_quality(single(fe::ElementType::Tri3, {{{0, 0, 0}}, {{1, 0, 0}}, {{0.5, h, 0}}}));
  ASSERT_EQ(tri.size(), 1u);
  EXPECT_NEAR(tri[0].aspect_ratio, 1, 1e-12);
  EXPECT_NEAR(tri[0].scaled_jacobian, 1, 1e-12);
  EXPECT_NEAR(tri[0].min_angle_deg, 60, 1e-9);
  EXPECT_FALSE(tri[0].inverted);

  const auto quad = fe::element_quality(single(fe::ElementType::Quad4, {{{0, 0, 0}}, {{2, 0, 0}}, {{2, 2, 0}}, {{0, 2, 0}}}));
  EXPECT_NEAR(quad[0].aspect_ratio, 1, 1e-12);
  EXPECT_NEAR(quad[0].scaled_jacobian, 1, 1e-12);
  EXPECT_NEAR(quad[0].min_angle_deg, 90, 1e-9);
  EXPECT_FALSE(quad[0].inverted);

  // regular tetrahedron, positive orientation
  const fe::FeMesh tet = single(fe::ElementType::Tet4, {{{1, 1, 1}}, {{-1, 1, -1}}, {{1, -1, -1}}, {{-1, -1, 1}}});
  const auto t = fe::element_quality(tet);
  EXPECT_NEAR(t[0].aspect_ratio, 1, 1e-12);
  EXPECT_NEAR(t[0].scaled_jacobian, 1, 1e-12);
  EXPECT_NEAR(t[0].min_angle_deg, 60, 1e-9);
  EXPECT_FALSE(t[0].inverted);
  fe::FeMesh flipped = tet;
  std::swap(flipped.blocks[0].conn(0, 1), flipped.blocks[0].conn(0, 2));
  const auto tf = fe::element_quality(flipped);
  EXPECT_NEAR(tf[0].scaled_jacobian, -1, 1e-12);
  EXPECT_TRUE(tf[0].inverted);

  const auto hex = fe::element_quality(single(fe::ElementType::Hex8, {{{0, 0, 0}}, {{1, 0, 0}}, {{1, 1, 0}}, {{0, 1, 0}},
                                                                      {{0, 0, 1}}, {{1, 0, 1}}, {{1, 1, 1}}, {{0, 1, 1}}}));
  EXPECT_NEAR(hex[0].aspect_ratio, 1, 1e-12);
  EXPECT_NEAR(hex[0].scaled_jacobian, 1, 1e-12);
  EXPECT_NEAR(hex[0].min_angle_deg, 90, 1e-9);
}

TEST(FeMeshQuality, DistortedAndDegenerate) {
  // 1 x 0.1 rectangle: aspect ratio 10, SJ 1; right isosceles triangle: 45 degrees, SJ 2/sqrt(3)/sqrt(2)
  const auto rect = fe::element_quality(single(fe::ElementType::Quad4, {{{0, 0, 0}}, {{1, 0, 0}}, {{1, 0.1, 0}}, {{0, 0.1, 0}}}));
  EXPECT_NEAR(rect[0].aspect_ratio, 10, 1e-9);
  EXPECT_NEAR(rect[0].scaled_jacobian, 1, 1e-12);
  const auto right = fe::element_quality(single(fe::ElementType::Tri3, {{{0, 0, 0}}, {{1, 0, 0}}, {{0, 1, 0}}}));
  EXPECT_NEAR(right[0].min_angle_deg, 45, 1e-9);
  EXPECT_NEAR(right[0].scaled_jacobian, 2 / std::sqrt(3.0) / std::sqrt(2.0), 1e-12);
  // a non-convex ("arrow") quad: negative corner Jacobian even without reference normals
  const auto arrow = fe::element_quality(single(fe::ElementType::Quad4, {{{0, 0, 0}}, {{2, 0, 0}}, {{0.5, 0.5, 0}}, {{0, 2, 0}}}));
  EXPECT_LT(arrow[0].scaled_jacobian, 0);
  EXPECT_TRUE(arrow[0].inverted);
  // collinear triangle
  const auto flat = fe::element_quality(single(fe::ElementType::Tri3, {{{0, 0, 0}}, {{1, 0, 0}}, {{2, 0, 0}}}));
  EXPECT_TRUE(std::isinf(flat[0].aspect_ratio));
  EXPECT_EQ(flat[0].scaled_jacobian, 0);
  EXPECT_FALSE(flat[0].inverted);
}

TEST(FeMeshQuality, FlippedShellAgainstReferenceNormals) {
  // two triangles and a quad in the z = 0 plane, all normals +z
  fe::FeMesh m;
  m.nodes.resize(6, 3);
  m.nodes << 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0, 2, 0, 0, 2, 1, 0;
  fe::ElementBlock tris{fe::ElementType::Tri3, {1, 2}, {}, ""};
  tris.conn.resize(2, 3);
  tris.conn << 0, 1, 2, 0, 2, 3;
  fe::ElementBlock quads{fe::ElementType::Quad4, {3}, {}, ""};
  quads.conn.resize(1, 4);
  quads.conn << 1, 4, 5, 2;
  m.blocks = {tris, quads};
  const fe::Points before = fe::element_normals(m);
  ASSERT_EQ(before.rows(), 3);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(before(i, 2), 1, 1e-12);

  // a "mapping" that mirrors the second triangle and the quad (node order reversed)
  std::swap(m.blocks[0].conn(1, 1), m.blocks[0].conn(1, 2));
  std::swap(m.blocks[1].conn(0, 1), m.blocks[1].conn(0, 3));
  const auto q = fe::element_quality(m, &before);
  ASSERT_EQ(q.size(), 3u);
  EXPECT_FALSE(q[0].inverted);
  EXPECT_GT(q[0].scaled_jacobian, 0);
  EXPECT_TRUE(q[1].inverted);
  EXPECT_LT(q[1].scaled_jacobian, 0);
  EXPECT_TRUE(q[2].inverted);
  EXPECT_NEAR(q[2].scaled_jacobian, -1, 1e-12);
  // without reference normals each shell is measured along its own normal: nothing inverted
  for (const auto& e : fe::element_quality(m)) EXPECT_FALSE(e.inverted);

  const fe::QualitySummary s = fe::summarize(q);
  EXPECT_EQ(s.elements, 3u);
  EXPECT_EQ(s.inverted, 2u);
  EXPECT_NEAR(s.min_scaled_jacobian, -1, 1e-12);
  EXPECT_NEAR(s.min_angle_deg, 45, 1e-9);
  EXPECT_NEAR(s.max_aspect_ratio, std::sqrt(3.0), 1e-12);  // right isosceles: longest edge / shortest altitude * sqrt(3)/2
  EXPECT_TRUE(std::isnan(fe::summarize({}).min_scaled_jacobian));

  fe::Points wrong(2, 3);
  EXPECT_THROW(fe::element_quality(m, &wrong), std::invalid_argument);
}

TEST(FeMeshWrite, InpNumbersFitCalculixsTwentyCharacters) {
  // CalculiX reads at most 20 characters of a number: -9.358640446443431e-17 (22) stopped it
  fe::FeMesh m;
  m.nodes.resize(3, 3);
  m.nodes << 19.841637952130124, 59.566329911224166, -9.358640446443431e-17, 1.0 / 3.0, -2.0 / 3.0, 1e-300, 0, 1, 0.5;
  fe::ElementBlock b;
  b.type = fe::ElementType::Tri3;
  b.conn.resize(1, 3);
  b.conn << 0, 1, 2;
  m.blocks.push_back(b);
  const std::string path = tmp("twenty.inp");
  fe::write_inp(m, path);
  std::ifstream in(path);
  std::string line;
  bool in_nodes = false;
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.rfind("*", 0) == 0) {
      in_nodes = line.rfind("*NODE", 0) == 0;
      continue;
    }
    if (!in_nodes) continue;
    ++rows;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, ',')) {
      const auto a = field.find_first_not_of(' ');
      EXPECT_LE(field.size() - (a == std::string::npos ? field.size() : a), 20u) << line;
    }
  }
  EXPECT_EQ(rows, 3);
  const fe::FeMesh back = fe::read_fe_mesh(path);
  for (int i = 0; i < 3; ++i)
    for (int c = 0; c < 3; ++c) EXPECT_NEAR(back.nodes(i, c), m.nodes(i, c), 1e-12 * std::max(1.0, std::abs(m.nodes(i, c))));
  EXPECT_EQ(back.nodes(0, 1), m.nodes(0, 1));  // what fits is still exact
}

// ------------------------------------------------------------------------------------------------
// Quadratic tetrahedra (issue 12: the solid is filled with C3D10)

namespace {
// Two tetrahedra sharing the face 0-1-2 (apexes 3 above and 4 below), positive volumes.
fe::FeMesh two_tets() {
  fe::FeMesh m;
  m.nodes.resize(5, 3);
  m.nodes << 0, 0, 0, 1, 0, 0, 0, 1, 0, 0.3, 0.3, 1, 0.3, 0.3, -1;
  m.node_ids = {10, 20, 30, 40, 50};
  fe::ElementBlock b;
  b.type = fe::ElementType::Tet4;
  b.elset = "SOLID";
  b.conn.resize(2, 4);
  b.conn << 0, 1, 2, 3, 0, 2, 1, 4;
  b.ids = {1, 2};
  m.blocks.push_back(b);
  m.node_sets["FACE"] = {0, 1, 2};
  m.node_sets["APEX"] = {3};
  return m;
}
Eigen::Vector3d at(const fe::FeMesh& m, int i) { return m.nodes.row(i).transpose(); }
}  // namespace

TEST(FeMeshQuadratic, MiddlesAreSharedAndSurfaceSetsTakeThem) {
  const fe::FeMesh lin = two_tets();
  const fe::FeMesh q = fe::to_quadratic(lin);
  ASSERT_EQ(q.blocks[0].type, fe::ElementType::Tet10);
  ASSERT_EQ(q.blocks[0].conn.cols(), 10);
  EXPECT_EQ(q.nodes.rows(), 5 + 9);  // 12 tetrahedron edges, 3 of them shared
  EXPECT_EQ(q.node_ids.size(), 14u);
  EXPECT_EQ(q.node_ids[5], 51);  // new ids after the largest
  static const int edge[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  for (Eigen::Index r = 0; r < 2; ++r)
    for (int e = 0; e < 6; ++e) {
      const auto& c = q.blocks[0].conn;
      EXPECT_TRUE(at(q, c(r, 4 + e)).isApprox(0.5 * (at(q, c(r, edge[e][0])) + at(q, c(r, edge[e][1])))));
    }
  // the shared face's three edge middles are one node each, used by both tetrahedra
  std::set<int> first(q.blocks[0].conn.row(0).data() + 4, q.blocks[0].conn.row(0).data() + 10);
  int shared = 0;
  for (int j = 4; j < 10; ++j) shared += first.count(q.blocks[0].conn(1, j)) ? 1 : 0;
  EXPECT_EQ(shared, 3);
  EXPECT_EQ(q.node_sets.at("FACE").size(), 6u);  // 3 corners + 3 middles
  EXPECT_EQ(q.node_sets.at("APEX").size(), 1u);
  // an edge said not to lie on the surface does not join
  const fe::FeMesh q2 = fe::to_quadratic(lin, [](int a, int b) { return !((a == 0 && b == 1) || (a == 1 && b == 0)); });
  EXPECT_EQ(q2.node_sets.at("FACE").size(), 5u);
  // straight edges: the same quality as the linear tetrahedra
  const auto ql = fe::element_quality(lin), qq = fe::element_quality(q);
  for (int e = 0; e < 2; ++e) {
    EXPECT_NEAR(qq[static_cast<std::size_t>(e)].scaled_jacobian, ql[static_cast<std::size_t>(e)].scaled_jacobian, 1e-12);
    EXPECT_FALSE(qq[static_cast<std::size_t>(e)].inverted);
  }
}

TEST(FeMeshQuadratic, CurvedMiddlesAreKeptUnlessTheyFoldATetrahedron) {
  const fe::FeMesh lin = two_tets();
  std::size_t moved = 99;
  // the middle of edge 0-1 a little off the straight line: kept, and the quality drops below 1x
  const fe::FeMesh bent = fe::to_quadratic(lin, {}, [](int a, int b, const Eigen::Vector3d& m) {
    return (a + b == 1) ? Eigen::Vector3d(m + Eigen::Vector3d(0, -0.05, 0)) : m;
  }, &moved);
  EXPECT_EQ(moved, 1u);
  const auto ql = fe::element_quality(lin), qb = fe::element_quality(bent);
  EXPECT_LT(qb[0].scaled_jacobian, ql[0].scaled_jacobian);
  EXPECT_GT(qb[0].scaled_jacobian, 0);
  // moved across the tetrahedra (past the opposite corner): it would fold them, so it goes back
  const fe::FeMesh folded = fe::to_quadratic(lin, {}, [](int a, int b, const Eigen::Vector3d& m) {
    return (a + b == 1) ? Eigen::Vector3d(m + Eigen::Vector3d(0, 1.5, 0)) : m;
  }, &moved);
  EXPECT_EQ(moved, 0u);
  for (const auto& e : fe::element_quality(folded)) EXPECT_FALSE(e.inverted);
  // the quality measure itself sees the fold
  fe::FeMesh forced = fe::to_quadratic(lin);
  const int mid01 = forced.blocks[0].conn(0, 4);
  forced.nodes.row(mid01) += Eigen::RowVector3d(0, 1.5, 0);
  EXPECT_TRUE(fe::element_quality(forced)[0].inverted);
  EXPECT_LT(fe::element_quality(forced)[0].scaled_jacobian, 0);
}

TEST(FeMeshQuadratic, AGivenTet10BlockIsKeptAndUnmovedMiddlesAreNotCounted) {
  // a mesh that already has a Tet10 block beside a Tet4 one: only the Tet4 block gets new middles,
  // and the fold check reads only those (the given block's middles are old nodes)
  fe::FeMesh lin = two_tets();
  fe::FeMesh mixed = fe::to_quadratic(lin);
  fe::ElementBlock t4;
  t4.type = fe::ElementType::Tet4;
  t4.conn.resize(1, 4);
  const Eigen::Index n = mixed.nodes.rows();
  mixed.nodes.conservativeResize(n + 1, 3);
  mixed.nodes.row(n) << 1.2, 1.2, 0.3;  // a third tetrahedron on face 1-2-3, outside
  mixed.node_ids.push_back(99);
  t4.conn << 2, 1, static_cast<int>(n), 3;
  ASSERT_GT(fe::element_quality([&] { fe::FeMesh one; one.nodes = mixed.nodes; one.blocks = {t4}; return one; }())[0].scaled_jacobian, 0);
  mixed.blocks.push_back(t4);
  std::size_t moved = 99;
  // place returns the straight middle up to rounding: nothing counts as moved
  const fe::FeMesh q = fe::to_quadratic(mixed, {}, [](int, int, const Eigen::Vector3d& m) { return Eigen::Vector3d(m * (1 + 1e-15)); }, &moved);
  EXPECT_EQ(moved, 0u);
  ASSERT_EQ(q.blocks.size(), 2u);
  EXPECT_EQ(q.blocks[0].conn, mixed.blocks[0].conn);  // the given Tet10 block unchanged
  EXPECT_EQ(q.blocks[1].type, fe::ElementType::Tet10);
  // its 6 edges: 1-2, 1-3 and 2-3 are the given block's, whose middles it shares; 3 middles are new
  EXPECT_EQ(q.nodes.rows(), n + 1 + 3);
  EXPECT_EQ(q.blocks[1].conn(0, 4), mixed.blocks[0].conn(0, 5));  // middle of 1-2: the first tetrahedron's edge 1-2
  // a fold among the new middles is still undone with the Tet10 block before it
  const int far = static_cast<int>(n);
  const Eigen::Vector3d push(-2.5, -2.5, 0.2);  // the middle of 2-n pushed back across the tetrahedron
  fe::FeMesh forced = q;
  forced.nodes.row(q.blocks[1].conn(0, 6)) += push.transpose();  // Tet10 node 6: the middle of its corners 2 and 0 (nodes n and 2)
  ASSERT_TRUE(fe::element_quality(forced)[2].inverted);           // kept there, it would fold the third tetrahedron
  const fe::FeMesh f = fe::to_quadratic(mixed, {}, [&](int a, int b, const Eigen::Vector3d& m) {
    return (std::min(a, b) == 2 && std::max(a, b) == far) ? Eigen::Vector3d(m + push) : m;
  }, &moved);
  EXPECT_EQ(moved, 0u);
  for (const auto& e : fe::element_quality(f)) EXPECT_FALSE(e.inverted);
}

TEST(FeMeshQuadratic, Tet10RoundTripsAndReadsGmshsNodeOrder) {
  const fe::FeMesh q = fe::to_quadratic(two_tets());
  for (const char* ext : {"inp", "msh"}) {
    const std::string path = tmp(std::string("tet10.") + ext);
    ext == std::string("inp") ? fe::write_inp(q, path) : fe::write_msh(q, path);
    const fe::FeMesh back = fe::read_fe_mesh(path);
    ASSERT_EQ(back.blocks.size(), 1u) << ext;
    EXPECT_EQ(back.blocks[0].type, fe::ElementType::Tet10) << ext;
    EXPECT_EQ(back.blocks[0].conn, q.blocks[0].conn) << ext;
    EXPECT_EQ(back.node_sets.at("FACE"), q.node_sets.at("FACE")) << ext;
  }
  std::stringstream inp;
  inp << std::ifstream(tmp("tet10.inp")).rdbuf();
  EXPECT_NE(inp.str().find("TYPE=C3D10"), std::string::npos);
  // gmsh's own order (as gmsh 4.8 writes it after setOrder(2)): middles of 01, 12, 20, 30, 32, 31
  const std::string msh = R"($MeshFormat
2.2 0 8
$EndMeshFormat
$Nodes
10
1 0 0 0
2 1 0 0
3 0 1 0
4 0 0 1
5 0.5 0 0
6 0.5 0.5 0
7 0 0.5 0
8 0 0 0.5
9 0 0.5 0.5
10 0.5 0 0.5
$EndNodes
$Elements
1
1 11 2 0 1 1 2 3 4 5 6 7 8 9 10
$EndElements
)";
  write(tmp("gmsh_tet10.msh"), msh);
  const fe::FeMesh g = fe::read_fe_mesh(tmp("gmsh_tet10.msh"));
  ASSERT_EQ(g.blocks[0].type, fe::ElementType::Tet10);
  const auto& c = g.blocks[0].conn;
  EXPECT_TRUE(at(g, c(0, 8)).isApprox(0.5 * (at(g, c(0, 1)) + at(g, c(0, 3)))));  // Abaqus node 9: edge 2-4
  EXPECT_TRUE(at(g, c(0, 9)).isApprox(0.5 * (at(g, c(0, 2)) + at(g, c(0, 3)))));  // Abaqus node 10: edge 3-4
  EXPECT_FALSE(fe::element_quality(g)[0].inverted);
}
