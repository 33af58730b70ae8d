// Issue 5: the surface refinement recovers a known projective map, axisymmetric features (bosses)
// are found with a clean symmetric fit, and a reference feature's FE mesh transferred onto every
// instance lies on the target surface without inverted elements. Models from FE_MODELS (generated
// with --suite), feature folders from Resources/library (or FE_FEATURES).
#include "featureextract/extract.h"
#include "featureextract/geometry.h"
#include "featureextract/io.h"
#include "featureextract/transfer.h"

#include "test_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cstdlib>
#include <random>

namespace {

using fe_test::models;

std::string features() {
  const char* d = std::getenv("FE_FEATURES");
  return d ? d : FE_FEATURES_DIR;
}

struct FeatureRun {
  fe::FeatureModel feature;
  fe::TriangleMesh ref, tgt;
  fe::Result result;
};

FeatureRun run_feature(const std::string& feature, const std::string& target) {
  FeatureRun r;
  r.feature = fe::read_feature(features() + "/" + feature);
  r.ref = fe::read_shape(r.feature.geometry_path);
  r.tgt = fe::read_shape(models() + "/suite/" + target, fe::tessellation_for_feature(r.ref.diagonal()));
  r.result = fe::extract(r.ref, r.tgt);
  return r;
}

}  // namespace

TEST(Refinement, RecoversAKnownProjectiveMapFromNoisySamples) {
  const fe::TriangleMesh ref = fe::read_shape(models() + "/rib_reference.step");
  const double L = ref.diagonal();
  // scale 1.3, shear, a mild perspective: a map the pipeline must recover, not just approximate
  Eigen::Matrix4d Ht = Eigen::Matrix4d::Identity();
  Ht.topLeftCorner<3, 3>() << 1.3, 0.15, 0.0, 0.0, 1.25, 0.1, 0.05, 0.0, 1.35;
  Ht.topRightCorner<3, 1>() << 40.0, -10.0, 5.0;
  Ht.block<1, 3>(3, 0) << 0.0015, -0.001, 0.0005;
  fe::TriangleMesh tgt = ref;
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.002 * L);
  for (Eigen::Index i = 0; i < tgt.vertices.rows(); ++i) {
    const Eigen::Vector3d y = fe::apply_transform(Ht, ref.vertices.row(i).transpose());
    tgt.vertices.row(i) = (y + Eigen::Vector3d(noise(rng), noise(rng), noise(rng))).transpose();
  }
  tgt.source = "mapped reference";
  const fe::Result r = fe::extract(ref, tgt);
  ASSERT_EQ(r.matches.size(), 1u);
  const fe::Match& m = r.matches[0];
  // The rib is symmetric under a half turn about its vertical axis (30, 40): both maps are right.
  Eigen::Matrix4d half = Eigen::Matrix4d::Identity();
  half.topLeftCorner<3, 3>() = Eigen::Vector3d(-1, -1, 1).asDiagonal();
  half.topRightCorner<3, 1>() << 60, 80, 0;
  double rms_map = INFINITY;
  for (const Eigen::Matrix4d& G : {Eigen::Matrix4d(Eigen::Matrix4d::Identity()), half}) {
    double sq = 0;
    for (Eigen::Index i = 0; i < ref.vertices.rows(); ++i) {
      const Eigen::Vector3d x = ref.vertices.row(i);
      sq += (fe::apply_transform(m.transform, x) - fe::apply_transform(Ht * G, x)).squaredNorm();
    }
    rms_map = std::min(rms_map, std::sqrt(sq / static_cast<double>(ref.vertices.rows())));
  }
  EXPECT_LT(rms_map, 0.01 * 1.3 * L) << "the found map differs from the true one";
  EXPECT_LE(m.rms_error, m.rms_error_unrefined + 1e-12) << "refinement must never make the fit worse";
  EXPECT_LT(m.rms_error, 0.01 * 1.3 * L);
}

TEST(Symmetry, FiveBossesOfDifferentSizesWithoutADummyShape) {
  const FeatureRun r = run_feature("boss", "bosses.step");
  EXPECT_EQ(r.result.symmetry, "axisymmetric");
  EXPECT_NEAR(r.result.symmetry_point.x(), 30.0, 0.1);
  EXPECT_NEAR(r.result.symmetry_point.y(), 30.0, 0.1);
  EXPECT_GT(std::abs(r.result.symmetry_axis.z()), 0.999);
  ASSERT_EQ(r.result.matches.size(), 5u);
  const double axis_x[] = {20, 58, 98, 140, 185}, radius[] = {4, 5, 6, 7.5, 9};
  for (int k = 0; k < 5; ++k) {
    const fe::Match* found = nullptr;
    for (const fe::Match& m : r.result.matches)
      if (std::abs(m.center.x() - axis_x[k]) < 5) found = &m;
    ASSERT_NE(found, nullptr) << "boss " << k;
    // the reference axis maps onto this boss's axis, with the boss's radius ratio and no spin or skew
    const Eigen::Vector3d p = fe::apply_transform(found->transform, Eigen::Vector3d(30, 30, 6));
    EXPECT_NEAR(p.x(), axis_x[k], 0.05) << "boss " << k;
    EXPECT_NEAR(p.y(), 35.0, 0.05) << "boss " << k;
    const Eigen::Matrix3d A = found->transform.topLeftCorner<3, 3>();
    EXPECT_NEAR(A(0, 0), radius[k] / 6.0, 0.01) << "boss " << k;
    EXPECT_NEAR(A(1, 1), radius[k] / 6.0, 0.01) << "boss " << k;
    EXPECT_LT(std::abs(A(0, 1)) + std::abs(A(1, 0)) + std::abs(A(0, 2)) + std::abs(A(1, 2)), 0.01) << "boss " << k;
    EXPECT_LT(found->rms_error, 0.005 * r.ref.diagonal() * found->scale) << "boss " << k;
  }
}

TEST(Symmetry, RealPartBossesAreAxisymmetricAndFound) {
  // NIST FTC-06: four identical bosses (radius 22.2 mm, counterbored holes), one as the reference.
  const fe::TriangleMesh ref = fe::read_shape(models() + "/suite/ftc06_boss_reference.step");
  const fe::TriangleMesh tgt = fe::read_shape(models() + "/suite/ftc06.step", fe::tessellation_for_feature(ref.diagonal()));
  const fe::Result r = fe::extract(ref, tgt);
  EXPECT_EQ(r.symmetry, "axisymmetric");
  EXPECT_GT(std::abs(r.symmetry_axis.z()), 0.999);
  EXPECT_GE(r.matches.size(), 3u);
  for (const fe::Match& m : r.matches) {
    bool on_a_boss = false;
    for (double x : {-108.6, -36.2, 36.2, 108.6}) on_a_boss = on_a_boss || std::abs(m.center.x() - x) < 2;
    EXPECT_TRUE(on_a_boss) << m.center.transpose();
    EXPECT_LT(m.rms_error, 0.005 * ref.diagonal());
  }
}

TEST(Transfer, BossMeshLiesOnEveryBossWithoutInvertedElements) {
  const FeatureRun r = run_feature("boss", "bosses.step");
  ASSERT_EQ(r.result.matches.size(), 5u);
  for (const fe::Match& m : r.result.matches) {
    const fe::TransferredMesh t = fe::transfer_mesh(r.feature.mesh, m.transform, r.tgt, {}, r.feature.spec_json);
    EXPECT_EQ(t.unprojected, 0u);
    EXPECT_LT(t.max_surface_distance, 1e-6);
    EXPECT_EQ(t.after_summary.inverted, 0u);
    EXPECT_TRUE(t.invalid_elements.empty());
    EXPECT_GT(t.after_summary.min_scaled_jacobian, 0.5);  // the reference's own worst is 0.58
    // the named sets travel with the mesh; the specification's axis is this boss's axis
    EXPECT_EQ(t.mesh.node_sets.count("BOLT_RIGID"), 1u);
    const auto spec = nlohmann::json::parse(t.spec_json);
    EXPECT_NEAR(spec["axis"]["point"][1].get<double>(), 35.0, 0.05);
    EXPECT_NEAR(std::abs(spec["axis"]["direction"][2].get<double>()), 1.0, 1e-3);
  }
}

TEST(Transfer, RibMeshOnFiveRibsOfDifferentWidthsOverSeeds) {
  // The ribs differ from the reference in top and bottom width (not an affine image of it): the
  // projection must leave almost every placed mesh clean (untangling), over several seeds. Not every
  // one: over seeds 1-10 about 1 instance in 10 keeps an inverted element or 20+ unprojected nodes
  // where the fit is poor (the same before and after issue 9's changes; see issue 12). Those are
  // flagged in invalid_elements, never hidden.
  const fe::FeatureModel feature = fe::read_feature(features() + "/rib");
  const fe::TriangleMesh ref = fe::read_shape(feature.geometry_path);
  const fe::TriangleMesh tgt = fe::read_shape(models() + "/suite/five_ribs.step", fe::tessellation_for_feature(ref.diagonal()));
  int placed = 0, clean = 0;
  for (std::uint64_t seed : {1, 2, 3, 4}) {
    fe::Params p;
    p.seed = seed;
    const fe::Result res = fe::extract(ref, tgt, p);
    ASSERT_EQ(res.matches.size(), 5u) << "seed " << seed;
    for (const fe::Match& m : res.matches) {
      const fe::TransferredMesh t = fe::transfer_mesh(feature.mesh, m.transform, tgt);
      ++placed;
      const bool ok = t.unprojected <= 20u && t.after_summary.inverted == 0u;
      clean += ok ? 1 : 0;
      EXPECT_EQ(t.invalid_elements.empty(), t.after_summary.inverted == 0u) << "inverted elements must be flagged";
      EXPECT_EQ(t.mesh.nodes.rows(), feature.mesh.nodes.rows());
      EXPECT_EQ(t.mesh.node_sets.at("RIB_TOP"), feature.mesh.node_sets.at("RIB_TOP"));
      if (t.unprojected == 0) EXPECT_LT(t.max_surface_distance, 1e-6);
    }
  }
  EXPECT_GE(clean, placed - 3) << clean << " of " << placed << " placed meshes clean";
}

TEST(Transfer, NodesFarFromTheSurfaceKeepTheMappedPosition) {
  const FeatureRun r = run_feature("boss", "bosses.step");
  ASSERT_FALSE(r.result.matches.empty());
  Eigen::Matrix4d lift = Eigen::Matrix4d::Identity();
  lift(2, 3) = 20.0;  // the whole mesh 20 mm above the boss: nothing to project onto
  const Eigen::Matrix4d H = lift * r.result.matches[0].transform;
  const fe::TransferredMesh t = fe::transfer_mesh(r.feature.mesh, H, r.tgt);
  EXPECT_EQ(t.projected, 0u);
  EXPECT_EQ(t.unprojected, static_cast<std::size_t>(r.feature.mesh.nodes.rows()));
  for (Eigen::Index i = 0; i < t.mesh.nodes.rows(); ++i)
    ASSERT_LT((t.mesh.nodes.row(i).transpose() - fe::apply_transform(H, r.feature.mesh.nodes.row(i).transpose())).norm(), 1e-9);
  EXPECT_GT(t.max_surface_distance, 5.0);
}

TEST(Transfer, ClosestPointOnTriangle) {
  const Eigen::Vector3d a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  EXPECT_TRUE(fe::closest_point_on_triangle({0.2, 0.2, 1}, a, b, c).isApprox(Eigen::Vector3d(0.2, 0.2, 0)));
  EXPECT_TRUE(fe::closest_point_on_triangle({-1, -1, 0}, a, b, c).isApprox(a));
  EXPECT_TRUE(fe::closest_point_on_triangle({2, -1, 0}, a, b, c).isApprox(b));
  EXPECT_TRUE(fe::closest_point_on_triangle({1, 1, 0}, a, b, c).isApprox(Eigen::Vector3d(0.5, 0.5, 0)));
  EXPECT_TRUE(fe::closest_point_on_triangle({0.5, -2, 3}, a, b, c).isApprox(Eigen::Vector3d(0.5, 0, 0)));
}

TEST(Transfer, FeatureFolderErrorsNameTheFile) {
  EXPECT_THROW(fe::read_feature("/nonexistent/feature"), fe::InputError);
  try {
    fe::read_feature(models());  // a folder without feature.json
    FAIL();
  } catch (const fe::InputError& e) {
    EXPECT_NE(std::string(e.what()).find("feature.json"), std::string::npos);
  }
}

namespace {

// A 10 x 10 quad grid on [0, 10]^2 (z = 0, normals +z), and a target whose face 1 is that square and
// whose face 2 slopes up from its edge x = 10 (30 degrees, like a root fillet the instance does not own).
fe::FeMesh grid_plate() {
  fe::FeMesh m;
  m.nodes.resize(121, 3);
  for (int j = 0; j <= 10; ++j)
    for (int i = 0; i <= 10; ++i) m.nodes.row(j * 11 + i) << i, j, 0;
  fe::ElementBlock b;
  b.type = fe::ElementType::Quad4;
  b.conn.resize(100, 4);
  for (int j = 0; j < 10; ++j)
    for (int i = 0; i < 10; ++i) {
      const int a = j * 11 + i;
      b.conn.row(j * 10 + i) << a, a + 1, a + 12, a + 11;
      b.ids.push_back(j * 10 + i + 1);
    }
  m.blocks.push_back(b);
  for (int v = 0; v < 121; ++v) m.node_ids.push_back(v + 1);
  return m;
}

fe::TriangleMesh plate_and_slope() {
  fe::TriangleMesh t;
  const double s = std::tan(30.0 * 3.14159265358979 / 180.0);
  t.vertices.resize(6, 3);
  t.vertices << 0, 0, 0, 10, 0, 0, 10, 10, 0, 0, 10, 0, 15, 0, 5 * s, 15, 10, 5 * s;
  t.triangles.resize(4, 3);
  t.triangles << 0, 1, 2, 0, 2, 3, 1, 4, 5, 1, 5, 2;
  t.face_ids.resize(4);
  t.face_ids << 1, 1, 2, 2;
  t.num_faces = 2;
  return t;
}

}  // namespace

TEST(Transfer, AFitPastTheFaceMorphsBackInsideInsteadOfFoldingOntoItsEdge) {
  // the fit puts the mesh 1.5 elements past face 1's edge; with feet on face 1 only (mesh-part's
  // claimed faces) the outer columns stop on the edge: folded onto it, unless the border's move is
  // spread over the interior (NIST CTC-02's mirrored lugs, three rows on the root edge)
  const fe::FeMesh ref = grid_plate();
  const fe::TriangleMesh target = plate_and_slope();
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
  H(0, 3) = 1.5;
  fe::TransferOptions o;
  o.max_projection = 0.2;  // reach 2.8: every node finds a foot
  o.faces = {1};
  const fe::TransferredMesh t = fe::transfer_mesh(ref, H, target, o);
  EXPECT_EQ(t.unprojected, 0u);
  EXPECT_GT(t.morphed, 50u);
  for (Eigen::Index i = 0; i < t.mesh.nodes.rows(); ++i) {
    ASSERT_LE(t.mesh.nodes(i, 0), 10 + 1e-9) << "node " << i << " past face 1";
    ASSERT_NEAR(t.mesh.nodes(i, 2), 0.0, 1e-9);
  }
  double worst = INFINITY;
  for (const fe::ElementQuality& q : t.after) worst = std::min(worst, q.scaled_jacobian);
  EXPECT_GT(worst, 0.8) << "columns folded onto the edge";
  // feet on any face: the outer columns go up the slope (what a lug's root fillet did)
  o.faces.clear();
  const fe::TransferredMesh any = fe::transfer_mesh(ref, H, target, o);
  Eigen::Index on_slope = 0;
  for (Eigen::Index i = 0; i < any.mesh.nodes.rows(); ++i) on_slope += any.mesh.nodes(i, 2) > 0.1;
  EXPECT_GT(on_slope, 10);
}

TEST(Transfer, AFitInsideTheFacesIsNotMorphed) {
  const fe::FeMesh ref = grid_plate();
  fe::TriangleMesh target = plate_and_slope();
  target.vertices.col(0) *= 2.0;  // face 1 is [0, 20] x [0, 10]: the fit lies inside it
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
  H(0, 3) = 1.5;
  H(2, 3) = 0.05;
  fe::TransferOptions o;
  o.max_projection = 0.2;
  o.faces = {1};
  const fe::TransferredMesh t = fe::transfer_mesh(ref, H, target, o);
  EXPECT_EQ(t.morphed, 0u);
  for (Eigen::Index i = 0; i < t.mesh.nodes.rows(); ++i)
    ASSERT_NEAR(t.mesh.nodes(i, 0), ref.nodes(i, 0) + 1.5, 1e-9);
}
