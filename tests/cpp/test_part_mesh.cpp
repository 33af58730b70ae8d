// One mesh of the whole part (issue 12): set names, patch borders, overlaps, the assembly of the
// mesher's answer with the patches (joined nodes, orientation, sets, conformity), the CalculiX deck.
// The mesher itself (gmsh) is exercised by tests/cli/test_mesh_part.py.
#include "featureextract/part_mesh.h"

#include "featureextract/geometry.h"
#include "featureextract/mesh.h"
#include "test_util.h"

#include <Eigen/LU>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>

namespace {

// A patch of one triangle (0,0,0) (1,0,0) (0,1,0), turned so that its normal is -z: the outward
// normal of the bottom face of the tetrahedron with apex (0,0,1).
fe::PartPatch one_triangle_patch() {
  fe::PartPatch p;
  p.name = "BOSS_1";
  p.feature = "boss";
  p.faces = {1};
  p.score = 0.9;
  p.mesh.nodes.resize(3, 3);
  p.mesh.nodes << 0, 0, 0, 1, 0, 0, 0, 1, 0;
  p.mesh.node_ids = {1, 2, 3};
  fe::ElementBlock b;
  b.type = fe::ElementType::Tri3;
  b.conn.resize(1, 3);
  b.conn << 0, 2, 1;
  b.ids = {1};
  b.elset = "BOSS";
  p.mesh.blocks.push_back(b);
  p.mesh.element_sets["BOSS"] = {0};
  p.mesh.node_sets["BOLT_RIGID"] = {0, 1};
  return p;
}

// The mesher's answer for the other three faces of the tetrahedron: the apex is the rest's own node
// (tag 7); tags 4, 5, 6 are the patch's nodes 0, 1, 2 (joined); triangles turned every which way.
const char* kAnswer = R"({
  "nodes": [[7, 0, 0, 1]],
  "triangles": [[2, 4, 5, 7], [3, 5, 6, 7], [4, 4, 6, 7]],
  "joined": [[4, 0], [5, 1], [6, 2]],
  "moved": [[1, 1, 0, 0]],
  "fixed_face": 2, "fixed_nodes": [7], "fixed_keys": [0, 1],
  "report": {"rest_faces": 3}
})";

// +1 / -1: the element runs a->b / b->a; 0: not an edge of it
int runs(const fe::FeMesh& m, int element, int a, int b) {
  int e = 0;
  for (const auto& bl : m.blocks)
    for (Eigen::Index r = 0; r < bl.conn.rows(); ++r, ++e)
      if (e == element) {
        const int n = static_cast<int>(bl.conn.cols());
        for (int k = 0; k < n; ++k) {
          if (bl.conn(r, k) == a && bl.conn(r, (k + 1) % n) == b) return 1;
          if (bl.conn(r, k) == b && bl.conn(r, (k + 1) % n) == a) return -1;
        }
      }
  return 0;
}

}  // namespace

TEST(PartMesh, SetNamesAreUpperCaseWordsJoinedByUnderscores) {
  EXPECT_EQ(fe::set_name("screw boss"), "SCREW_BOSS");
  EXPECT_EQ(fe::set_name("  rib -- 2.5mm "), "RIB_2_5MM");
  EXPECT_EQ(fe::set_name("***"), "FEATURE");
}

TEST(PartMesh, BorderNodesAreThoseOfFreeEdges) {
  // 2 x 2 quads on a 3 x 3 grid of nodes: all but the centre node are on the border
  fe::FeMesh m;
  m.nodes.resize(9, 3);
  for (int i = 0; i < 9; ++i) m.nodes.row(i) << i % 3, i / 3, 0;
  fe::ElementBlock b;
  b.type = fe::ElementType::Quad4;
  b.conn.resize(4, 4);
  b.conn << 0, 1, 4, 3, 1, 2, 5, 4, 3, 4, 7, 6, 4, 5, 8, 7;
  m.blocks.push_back(b);
  EXPECT_EQ(fe::border_nodes(m), (std::vector<int>{0, 1, 2, 3, 5, 6, 7, 8}));
}

namespace {

// A flat part of three faces at z = 0: face 1 [0,2] x [0,2], face 2 [2,10] x [0,2] beside it, face 3
// [0,2] x [5,6] apart; two triangles each.
fe::TriangleMesh three_flat_faces() {
  fe::TriangleMesh t;
  t.num_faces = 3;
  t.vertices.resize(12, 3);
  const double sq[3][4] = {{0, 2, 0, 2}, {2, 10, 0, 2}, {0, 2, 5, 6}};  // x0 x1 y0 y1
  for (int f = 0; f < 3; ++f) {
    const auto& r = sq[f];
    t.vertices.row(4 * f + 0) << r[0], r[2], 0;
    t.vertices.row(4 * f + 1) << r[1], r[2], 0;
    t.vertices.row(4 * f + 2) << r[1], r[3], 0;
    t.vertices.row(4 * f + 3) << r[0], r[3], 0;
  }
  t.triangles.resize(6, 3);
  t.face_ids.resize(6);
  for (int f = 0; f < 3; ++f) {
    t.triangles.row(2 * f) << 4 * f, 4 * f + 1, 4 * f + 2;
    t.triangles.row(2 * f + 1) << 4 * f, 4 * f + 2, 4 * f + 3;
    t.face_ids(2 * f) = t.face_ids(2 * f + 1) = f + 1;
  }
  return t;
}

// Quads on the grid x in {0, 1, 2, last}, y in {0, 1, 2}: 2 x 2 on face 1, and a column of 2 that
// spills onto face 2 (within the mesher's reach, 1.5 edges, of under half of it).
fe::PartPatch spilling_patch(double last) {
  fe::PartPatch p;
  p.name = "LUG_1";
  const double xs[4] = {0, 1, 2, last};
  p.mesh.nodes.resize(12, 3);
  for (int j = 0; j < 3; ++j)
    for (int i = 0; i < 4; ++i) p.mesh.nodes.row(4 * j + i) << xs[i], j, 0;
  fe::ElementBlock b;
  b.type = fe::ElementType::Quad4;
  b.conn.resize(6, 4);
  int r = 0;
  for (int j = 0; j < 2; ++j)
    for (int i = 0; i < 3; ++i) b.conn.row(r++) << 4 * j + i, 4 * j + i + 1, 4 * (j + 1) + i + 1, 4 * (j + 1) + i;
  b.ids = {1, 2, 3, 4, 5, 6};
  p.mesh.blocks.push_back(b);
  p.mesh.element_sets["EDGE"] = {2, 4, 5};         // the last is a spilling element, the middle one is not
  p.mesh.node_sets["RIGHT"] = {2, 3, 6, 7, 10, 11};  // x = 2 and x = last
  p.reference_scaled_jacobian = {0.1, 0.2, 0.3, 0.4, 0.5, 0.6};
  return p;
}

}  // namespace

TEST(PartMeshClaim, AFaceTheMeshOnlyComesNearIsLeftToTheRestAndTheElementsOnItGo) {
  fe::PartPatch p = spilling_patch(3.2);  // the spilled column's centroids 0.6 off face 1: on face 2
  p.faces = {1, 2, 3};
  const fe::ClaimReport c = fe::claim_covered_faces(p, three_flat_faces());
  EXPECT_EQ(p.faces, (std::vector<int>{1}));
  EXPECT_EQ(c.dropped_faces, (std::vector<int>{2, 3}));
  EXPECT_EQ(c.removed_elements, 2u);
  ASSERT_EQ(p.mesh.num_elements(), 4u);
  ASSERT_EQ(p.mesh.nodes.rows(), 9);  // the three nodes at x = 3.2 went
  EXPECT_LE(p.mesh.nodes.col(0).maxCoeff(), 2.0);
  EXPECT_EQ(p.reference_scaled_jacobian, (std::vector<double>{0.1, 0.2, 0.4, 0.5}));
  EXPECT_EQ(p.mesh.element_sets["EDGE"], (std::vector<int>{3}));  // element 4 (0-based) is now the 4th
  ASSERT_EQ(p.mesh.node_sets["RIGHT"].size(), 3u);
  for (const int v : p.mesh.node_sets["RIGHT"]) EXPECT_DOUBLE_EQ(p.mesh.nodes(v, 0), 2.0);
  EXPECT_EQ(p.mesh.blocks[0].ids, (std::vector<long>{1, 2, 4, 5}));
  // the border now runs along the edge x = 2 between the kept face and the dropped one
  int on_edge = 0;
  for (const int v : fe::border_nodes(p.mesh)) on_edge += p.mesh.nodes(v, 0) == 2.0;
  EXPECT_EQ(on_edge, 3);
}

TEST(PartMeshClaim, ElementsThatOnlyReachOverTheEdgeOfAKeptFaceStay) {
  // a fit a hair off: the last column reaches half a unit over face 1's edge (centroids 0.25 off,
  // under half the median edge): face 2 is still left to the rest, but no element goes (the mesher
  // puts the border onto the edge)
  fe::PartPatch p = spilling_patch(2.5);
  p.faces = {1, 2};
  const fe::ClaimReport c = fe::claim_covered_faces(p, three_flat_faces());
  EXPECT_EQ(p.faces, (std::vector<int>{1}));
  EXPECT_EQ(c.dropped_faces, (std::vector<int>{2}));
  EXPECT_EQ(c.removed_elements, 0u);
  EXPECT_EQ(p.mesh.num_elements(), 6u);
}

TEST(PartMeshClaim, FacesTheMeshCoversStayClaimedAndNothingMoves) {
  fe::PartPatch p = spilling_patch(2.5);
  p.faces = {1};
  const fe::PartPatch before = p;
  const fe::ClaimReport c = fe::claim_covered_faces(p, three_flat_faces());
  EXPECT_TRUE(c.dropped_faces.empty());
  EXPECT_EQ(c.removed_elements, 0u);
  EXPECT_EQ(p.faces, before.faces);
  EXPECT_EQ(p.mesh.num_elements(), before.mesh.num_elements());
  EXPECT_TRUE(p.mesh.nodes.isApprox(before.mesh.nodes));
}

TEST(PartMeshClaim, AFaceUnderAPatchThatSitsAnEdgeOffStaysClaimed) {
  // a fit off by a whole edge along the normal (a stretched rib's side wall) still covers its face:
  // the mesher reaches 1.5 edges
  fe::PartPatch p = spilling_patch(2.5);
  p.mesh.nodes.col(2).array() += 1.0;
  p.faces = {1};
  const fe::ClaimReport c = fe::claim_covered_faces(p, three_flat_faces());
  EXPECT_TRUE(c.dropped_faces.empty());
  EXPECT_EQ(p.faces, (std::vector<int>{1}));
  // and two edges off, it does not
  p.mesh.nodes.col(2).array() += 1.0;
  EXPECT_EQ(fe::claim_covered_faces(p, three_flat_faces()).dropped_faces, (std::vector<int>{1}));
}

TEST(PartMesh, TheTransitionZoneIsScaledAsTheInstanceIsWhereItsPatchLies) {
  // A projective fit (perspective row -0.02 along x): around x = 25 the instance is about 1.7 times
  // the reference, while the transform's upper 3 x 3 is the identity. The mesher must get the zone's
  // width scaled as the instance is there, as check_rules scales the element size.
  fe::PartPatch p = one_triangle_patch();
  p.mesh.nodes.col(0).array() += 25.0;
  p.spec_json = R"({"rules": [{"rule": "transition_zone", "width": 2}],
                    "transform": [[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [-0.02, 0, 0, 1]]})";
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
  H(3, 0) = -0.02;
  const Eigen::Vector3d centroid = p.mesh.nodes.colwise().mean().transpose();
  const double scale = std::cbrt(std::abs(fe::transform_jacobian(H, fe::apply_transform(H.inverse(), centroid)).determinant()));
  ASSERT_GT(scale, 1.5);
  const auto job = nlohmann::json::parse(fe::part_mesh_job("part.step", 4, 5.0, {p}, false, 0.1, {}));
  ASSERT_TRUE(job["patches"][0].contains("transition"));
  EXPECT_NEAR(job["patches"][0]["transition"]["width"].get<double>(), 2 * scale, 1e-6);
}

TEST(PartMesh, OfTwoPatchesOnTheSameFacesTheBetterStays) {
  std::vector<fe::PartPatch> ps(3);
  ps[0].name = "RIB_1", ps[0].faces = {1, 2}, ps[0].score = 0.7;
  ps[1].name = "BOSS_1", ps[1].faces = {2, 3}, ps[1].score = 0.9;
  ps[2].name = "RIB_2", ps[2].faces = {4}, ps[2].score = 0.5;
  const auto lines = fe::resolve_overlaps(ps);
  ASSERT_EQ(ps.size(), 2u);
  EXPECT_EQ(ps[0].name, "BOSS_1");
  EXPECT_EQ(ps[1].name, "RIB_2");
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find("RIB_1"), std::string::npos);
  EXPECT_NE(lines[0].find("BOSS_1"), std::string::npos);
}

TEST(PartMesh, TheRestJoinsThePatchIntoOneClosedConsistentlyTurnedSurface) {
  const std::vector<fe::PartPatch> patches{one_triangle_patch()};
  fe::PartMeshReport rep;
  const fe::FeMesh m = fe::assemble_part_mesh(patches, kAnswer, &rep);
  ASSERT_EQ(m.nodes.rows(), 4);  // the three joined nodes are the patch's: no duplicates
  ASSERT_EQ(m.num_elements(), 4u);
  EXPECT_EQ(rep.joined_nodes, 3u);
  EXPECT_EQ(rep.duplicate_nodes, 0u);
  EXPECT_EQ(rep.free_edges, 0u);
  EXPECT_EQ(rep.border_nodes_not_joined, 0u);
  EXPECT_EQ(rep.fixed_face, 2);
  EXPECT_EQ(rep.moved_nodes, 1u);
  // every edge runs one way in one element and the other way in the other: one orientation
  const std::vector<std::pair<int, int>> edges{{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};
  for (const auto& [a, b] : edges) {
    int sum = 0, uses = 0;
    for (int e = 0; e < 4; ++e) {
      const int r = runs(m, e, a, b);
      sum += r;
      uses += r != 0;
    }
    EXPECT_EQ(uses, 2) << a << "-" << b;
    EXPECT_EQ(sum, 0) << a << "-" << b;
  }
  // the patch keeps its turn (outward, -z), so the closed surface encloses a positive volume
  EXPECT_EQ(runs(m, 0, 0, 2), 1);
  double vol = 0;
  int e = 0;
  for (const auto& bl : m.blocks)
    for (Eigen::Index r = 0; r < bl.conn.rows(); ++r, ++e) {
      const Eigen::Vector3d p0 = m.nodes.row(bl.conn(r, 0)).transpose(), p1 = m.nodes.row(bl.conn(r, 1)).transpose(),
                            p2 = m.nodes.row(bl.conn(r, 2)).transpose();
      vol += p0.dot(p1.cross(p2)) / 6;
    }
  EXPECT_NEAR(vol, 1.0 / 6, 1e-12);
  // sets: the patch's renamed, its own, the rest, the support
  EXPECT_EQ(m.element_sets.at("BOSS_1"), (std::vector<int>{0}));
  EXPECT_EQ(m.element_sets.at("BOSS_1_BOSS"), (std::vector<int>{0}));
  EXPECT_EQ(m.element_sets.at("PART_REST"), (std::vector<int>{1, 2, 3}));
  EXPECT_EQ(m.node_sets.at("BOSS_1_BOLT_RIGID"), (std::vector<int>{0, 1}));
  EXPECT_EQ(m.node_sets.at("FIXED"), (std::vector<int>{0, 1, 3}));
  EXPECT_EQ(m.blocks.back().elset, "PART_REST");
}

TEST(PartMesh, AnAnswerThatDoesNotFitThePatchesIsAnError) {
  const std::vector<fe::PartPatch> patches{one_triangle_patch()};
  for (const std::string bad : {std::string("not json"), std::string(R"({"nodes": []})"),
                                std::string(R"({"nodes": [], "triangles": [[2, 4, 5, 9]], "joined": [], "moved": []})"),
                                std::string(R"({"nodes": [], "triangles": [], "joined": [[4, 99]], "moved": []})")}) {
    try {
      fe::assemble_part_mesh(patches, bad);
      ADD_FAILURE() << "accepted: " << bad;
    } catch (const fe::InputError& e) {
      EXPECT_EQ(std::string(e.what()).rfind("fe_gmsh_rest: ", 0), 0u) << e.what();
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
    }
  }
}

TEST(PartMesh, TheAnalysisDeckHoldsThePartAndLoadsEachBoltThroughARigidBody) {
  const std::vector<fe::PartPatch> patches{one_triangle_patch()};
  const fe::FeMesh m = fe::assemble_part_mesh(patches, kAnswer);
  fe::StaticAnalysis a;
  a.rigid_sets = {"BOSS_1_BOLT_RIGID", "NO_SUCH_SET"};
  a.section_sets = {"BOSS_1", "PART_REST"};
  a.force = 50;
  const std::string path = ::testing::TempDir() + "fe_part_analysis.inp";
  fe::write_ccx_static(m, "part.inp", a, path);
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  const std::string deck = ss.str();
  EXPECT_NE(deck.find("*INCLUDE, INPUT=part.inp"), std::string::npos);
  // a reference node after the mesh's last (4), at the centroid of the bolt set's nodes 0 and 1
  EXPECT_NE(deck.find("5, 0.5, 0, 0"), std::string::npos) << deck;
  EXPECT_NE(deck.find("*RIGID BODY, NSET=BOSS_1_BOLT_RIGID, REF NODE=5"), std::string::npos);
  EXPECT_EQ(deck.find("NO_SUCH_SET"), std::string::npos);  // a set that is not there is not loaded
  EXPECT_NE(deck.find("*SHELL SECTION, ELSET=BOSS_1, MATERIAL=STEEL"), std::string::npos);
  EXPECT_NE(deck.find("*SHELL SECTION, ELSET=PART_REST, MATERIAL=STEEL"), std::string::npos);
  EXPECT_NE(deck.find("*BOUNDARY\nFIXED, 1, 6"), std::string::npos);
  EXPECT_NE(deck.find("*CLOAD\n5, 3, -50"), std::string::npos);
  EXPECT_NE(deck.find("*NSET, NSET=PART_NODES, GENERATE\n1, 4, 1"), std::string::npos);
}

// The solver's numbering: a strip of quads numbered across (ids jump by the strip's length between
// neighbours) gets ids 1..N again, neighbours close in id (a small profile for the solver), the same
// every time; an isolated node and a second component are numbered too.
TEST(PartMesh, NodesAreNumberedForTheSolverInCuthillMcKeeOrder) {
  const int len = 40;  // 2 x len nodes, len - 1 quads; row r: nodes r and len + r
  fe::FeMesh m;
  m.nodes.resize(2 * len + 4, 3);
  for (int r = 0; r < len; ++r) {
    m.nodes.row(r) << r, 0, 0;
    m.nodes.row(len + r) << r, 1, 0;
  }
  m.nodes.row(2 * len) << 100, 0, 0;  // isolated
  m.nodes.bottomRows(3) << 200, 0, 0, 201, 0, 0, 200, 1, 0;  // a triangle of its own
  fe::ElementBlock q;
  q.type = fe::ElementType::Quad4;
  q.conn.resize(len - 1, 4);
  for (int r = 0; r + 1 < len; ++r) q.conn.row(r) << r, r + 1, len + r + 1, len + r;
  fe::ElementBlock t;
  t.type = fe::ElementType::Tri3;
  t.conn.resize(1, 3);
  t.conn << 2 * len + 1, 2 * len + 2, 2 * len + 3;
  m.blocks = {q, t};
  m.node_sets["END"] = {0, len};
  auto bandwidth = [&](const std::vector<long>& id) {
    long w = 0;
    for (Eigen::Index r = 0; r < q.conn.rows(); ++r)
      for (int i = 0; i < 4; ++i)
        for (int k = 0; k < 4; ++k) w = std::max(w, std::abs(id[q.conn(r, i)] - id[q.conn(r, k)]));
    return w;
  };
  for (int i = 0; i < m.nodes.rows(); ++i) m.node_ids.push_back(i + 1);
  EXPECT_EQ(bandwidth(m.node_ids), len + 1);
  fe::number_nodes_for_solver(m);
  std::vector<long> sorted = m.node_ids;
  std::sort(sorted.begin(), sorted.end());
  for (std::size_t k = 0; k < sorted.size(); ++k) ASSERT_EQ(sorted[k], static_cast<long>(k) + 1);
  EXPECT_LE(bandwidth(m.node_ids), 3);
  EXPECT_EQ(m.node_sets["END"], (std::vector<int>{0, len}));  // sets hold rows, untouched
  const std::vector<long> first = m.node_ids;
  fe::number_nodes_for_solver(m);
  EXPECT_EQ(m.node_ids, first);
}

namespace {

// A strip bent along x = 2: the floor z = 0 for u = x <= 2, the wall x = 2 (z = u - 2) beyond.
Eigen::Vector3d bent(double u, double y) { return u <= 2 ? Eigen::Vector3d(u, y, 0) : Eigen::Vector3d(2, y, u - 2); }

// The part's surface: the bent strip u in [-1, 5], y in [-1, 5] triangulated at 0.5.
fe::TriangleMesh bent_surface() {
  return fe_test::grid_mesh(13, [](int i, int j) { return bent(-1 + 0.5 * i, -1 + 0.5 * j); });
}

// A patch of 4 x 4 unit quads on the bent strip, u and y in [0, 4]; node (i, j) is row 5 i + j.
fe::FeMesh bent_patch() {
  fe::FeMesh m;
  m.nodes.resize(25, 3);
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) m.nodes.row(5 * i + j) = bent(i, j).transpose();
  fe::ElementBlock b;
  b.type = fe::ElementType::Quad4;
  b.conn.resize(16, 4);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) b.conn.row(4 * i + j) << 5 * i + j, 5 * (i + 1) + j, 5 * (i + 1) + j + 1, 5 * i + j + 1;
  m.blocks.push_back(b);
  for (int i = 0; i < 25; ++i) m.node_ids.push_back(i + 1);
  return m;
}

std::vector<int> border_of_bent_patch() {
  std::vector<int> out;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j)
      if (i == 0 || j == 0 || i == 4 || j == 4) out.push_back(5 * i + j);
  return out;
}

}  // namespace

TEST(PartMeshRepair, AFoldedNodeGoesBackAndEveryElementMeetsTheGoal) {
  fe::FeMesh m = bent_patch();
  const fe::FeMesh before = m;
  m.nodes.row(5 * 1 + 2) << 1.9, 2.95, 0;  // node (1, 2) pushed over its neighbours: folded and poor quads
  const fe::RepairReport r = fe::repair_patches(m, 16, bent_surface(), border_of_bent_patch(), 0.3, 20);
  EXPECT_GT(r.inverted_before, 0u);
  EXPECT_GT(r.poor_before, 0u);
  EXPECT_EQ(r.inverted_after, 0u);
  EXPECT_EQ(r.poor_after, 0u);
  EXPECT_GE(r.moved_nodes, 1u);
  for (const auto& q : fe::element_quality(m)) EXPECT_GE(q.scaled_jacobian, 0.3);
  for (const int v : border_of_bent_patch()) EXPECT_EQ((m.nodes.row(v) - before.nodes.row(v)).norm(), 0.0) << v;  // locked
  EXPECT_NEAR(m.nodes(7, 2), 0.0, 1e-9);  // on the floor still
}

TEST(PartMeshRepair, AMoveNeverRoundsOffASharpEdgeOfThePart) {
  fe::FeMesh m = bent_patch();
  // the floor node (1, 2) pushed toward the bend and held there (as a border node would be): the quads
  // around it are poor, and sliding the bend's nodes (2, 1..3) up the wall would raise them, but cut
  // the part's edge off
  m.nodes.row(5 * 1 + 2) << 1.85, 2.4, 0;
  std::vector<int> locked = border_of_bent_patch();
  locked.push_back(5 * 1 + 2);
  const fe::RepairReport r = fe::repair_patches(m, 16, bent_surface(), locked, 0.3, 20);
  EXPECT_GT(r.poor_before, 0u);
  EXPECT_EQ(r.inverted_after, 0u);
  for (int j = 1; j <= 3; ++j) {
    const Eigen::Vector3d p = m.nodes.row(5 * 2 + j).transpose();
    EXPECT_LT(std::hypot(p.x() - 2, p.z()), 0.03) << "bend node " << j << " at " << p.transpose();
  }
}

TEST(PartMeshRepair, WithNothingPoorNothingMoves) {
  fe::FeMesh m = bent_patch();
  const fe::FeMesh before = m;
  const fe::RepairReport r = fe::repair_patches(m, 16, bent_surface(), border_of_bent_patch(), 0.3, 20);
  EXPECT_EQ(r.poor_before, 0u);
  EXPECT_EQ(r.moved_nodes, 0u);
  EXPECT_EQ(r.passes, 0);
  EXPECT_EQ((m.nodes - before.nodes).norm(), 0.0);
}
