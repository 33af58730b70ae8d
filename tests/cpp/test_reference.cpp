// References as users make them (issue 9): box-cut solids with cut faces, closed STL cuts, mirror
// images, features made of planes (sharp creases). Models from fe_make_models (FE_MODELS).
#include "featureextract/extract.h"
#include "featureextract/geometry.h"
#include "featureextract/io.h"
#include "featureextract/reference.h"
#include "featureextract/transfer.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <Eigen/Dense>
#include <algorithm>
#include <cstdlib>
#include <fstream>
#include <thread>

namespace {

using fe_test::models;
using fe_test::truth;
using fe_test::match_near;

fe::Result run(const std::string& ref, const std::string& tgt, const fe::Params& p = {}) {
  const fe::TriangleMesh r = fe::read_shape(models() + "/" + ref);
  const fe::TriangleMesh t = fe::read_shape(models() + "/" + tgt, fe::tessellation_for_feature(r.diagonal()));
  return fe::extract(r, t, p);
}

// A unit cube [0,1]^3 as 12 outward triangles, optionally without its top (+z) face.
fe::TriangleMesh cube(bool open_top) {
  fe::TriangleMesh m;
  m.vertices.resize(8, 3);
  for (int i = 0; i < 8; ++i) m.vertices.row(i) << (i & 1), (i >> 1) & 1, (i >> 2) & 1;
  const int t[12][3] = {{0, 2, 1}, {1, 2, 3}, {4, 5, 6}, {5, 7, 6}, {0, 1, 4}, {1, 5, 4},
                        {2, 6, 3}, {3, 6, 7}, {0, 4, 2}, {2, 4, 6}, {1, 3, 5}, {3, 7, 5}};
  const int n = open_top ? 10 : 12;
  m.triangles.resize(n, 3);
  int k = 0;
  for (int i = 0; i < 12; ++i) {
    if (open_top && (i == 2 || i == 3)) continue;
    m.triangles.row(k++) << t[i][0], t[i][1], t[i][2];
  }
  m.face_ids = Eigen::VectorXi::Zero(n);
  return m;
}

}  // namespace

TEST(CutFaces, BoxCutRibHasItsSidesAndBottomCutButNotItsTop) {
  // the first rib of ribs_bosses.step cut out with a box reaching below the plate and above the rib
  const fe::TriangleMesh ref = fe::read_shape(models() + "/rib_boxcut_reference.brep");
  const fe::CutFaces c = fe::detect_cut_faces(ref);
  EXPECT_TRUE(c.closed);
  ASSERT_EQ(c.faces.size(), 5u);  // 4 box sides and the plate bottom inside the box
  // the rib's top face lies on the box's top plane but reaches no other side: kept
  const Eigen::Vector3d hi = ref.vertices.colwise().maxCoeff().transpose();
  for (Eigen::Index t = 0; t < ref.triangles.rows(); ++t) {
    bool on_top = true;
    for (int k = 0; k < 3; ++k) on_top = on_top && std::abs(ref.vertices(ref.triangles(t, k), 2) - hi.z()) < 1e-6;
    if (on_top) EXPECT_FALSE(c.cut_triangle[static_cast<std::size_t>(t)]) << "rib top triangle " << t << " marked cut";
  }
  const fe::TriangleMesh kept = fe::without_triangles(ref, c.cut_triangle);
  EXPECT_EQ(static_cast<std::size_t>(kept.triangles.rows()), static_cast<std::size_t>(ref.triangles.rows()) - c.triangles);
}

TEST(CutFaces, PickedFacesAreAnOpenShellWithNothingCut) {
  const fe::CutFaces c = fe::detect_cut_faces(fe::read_shape(models() + "/rib_reference.step"));
  EXPECT_FALSE(c.closed);
  EXPECT_EQ(c.triangles, 0u);
  EXPECT_TRUE(c.faces.empty());
  EXPECT_FALSE(c.any_side_cut());  // picked faces end at the feature's edges, not at a cut
}

// Faces that reach a picked reference's open border may end sooner on an instance (max_overhang):
// the four sides of a box without its top reach the open rim, its bottom does not; a closed box has
// no such face, and a mesh without B-rep faces gives none.
TEST(CutFaces, TheFacesReachingTheOpenBorderAreTheOnesAroundIt) {
  fe::TriangleMesh m = cube(true);
  const int face_of[12] = {1, 1, 0, 0, 2, 2, 3, 3, 4, 4, 5, 5};  // -z, (+z), -y, +y, -x, +x
  m.face_ids.resize(m.triangles.rows());
  for (int i = 0, k = 0; i < 12; ++i)
    if (face_of[i] > 0) m.face_ids(k++) = face_of[i];
  m.num_faces = 5;
  EXPECT_EQ(fe::faces_on_border(m), (std::vector<char>{0, 0, 1, 1, 1, 1}));
  fe::TriangleMesh closed = cube(false);
  const int closed_face_of[12] = {1, 1, 6, 6, 2, 2, 3, 3, 4, 4, 5, 5};
  for (int i = 0; i < 12; ++i) closed.face_ids(i) = closed_face_of[i];
  closed.num_faces = 6;
  EXPECT_EQ(fe::faces_on_border(closed), std::vector<char>(7, 0));
  EXPECT_TRUE(fe::faces_on_border(cube(true)).empty());
}

TEST(CutFaces, StlRegionClippedByABoxIsOpenAndCutAlongItsBorder) {
  // the first rib (x 24.7-35.3, y 18.5-61.5, z 0-12 on a plate 6 thick) clipped out of the plate's
  // tessellation with a box 20 % larger, as from an STL: an open region whose border runs along the
  // box's four vertical sides; the box's top and bottom reach no surface, so they are not cut
  const fe::TriangleMesh plate = fe::read_shape(models() + "/ribs_bosses.step");
  const fe::TriangleMesh ref = fe_test::clip_to_box(plate, {15, 9, -9}, {45, 71, 21});
  ASSERT_GT(ref.triangles.rows(), 20);
  const fe::CutFaces c = fe::detect_cut_faces(ref);
  EXPECT_FALSE(c.closed);
  EXPECT_EQ(c.triangles, 0u);  // nothing to leave out: no cap closes it
  for (int s = 0; s < 4; ++s) EXPECT_TRUE(c.cut_sides[static_cast<std::size_t>(s)]) << "side " << s;
  EXPECT_FALSE(c.cut_sides[4]);  // the plate's bottom lies on the box's -z side but is surface
  EXPECT_FALSE(c.cut_sides[5]);  // the rib's top
  // the plate's bottom spans the box's -z side, but nothing spans +z (the rib's top reaches only the
  // rib's ends): the region does not pass through between them, and nothing is left out
  EXPECT_EQ(c.own_triangles, 0u);
}

TEST(CutFaces, AStlRegionAcrossAPlateKeepsItsTwoFacesAsThePartsOwn) {
  // counterbore_boss.step's reference hole (x 30, y 35, through the 24 mm plate: z -24 to 0) clipped
  // with a box reaching past both of the plate's faces, as from an STL: clipped along its four
  // vertical sides; the plate's top and bottom, each spanning the box from side to side, are the
  // two faces of the wall the hole passes through, where the box reached past the part (issue 9)
  const fe::TriangleMesh part = fe::read_shape(models() + "/counterbore_boss.step");
  const fe::TriangleMesh ref = fe_test::clip_to_box(part, {19, 24, -30}, {41, 46, 6});
  const fe::CutFaces c = fe::detect_cut_faces(ref);
  EXPECT_FALSE(c.closed);
  for (int s = 0; s < 4; ++s) EXPECT_TRUE(c.cut_sides[static_cast<std::size_t>(s)]) << "side " << s;
  EXPECT_FALSE(c.cut_sides[4]);
  EXPECT_FALSE(c.cut_sides[5]);
  ASSERT_EQ(c.own_triangle.size(), static_cast<std::size_t>(ref.triangles.rows()));
  std::size_t top = 0, bottom = 0, planar = 0;
  for (Eigen::Index t = 0; t < ref.triangles.rows(); ++t) {
    const double z0 = ref.vertices(ref.triangles(t, 0), 2), z1 = ref.vertices(ref.triangles(t, 1), 2), z2 = ref.vertices(ref.triangles(t, 2), 2);
    const bool on_top = std::max({z0, z1, z2}) > -1e-6 && std::min({z0, z1, z2}) > -1e-6;
    const bool on_bottom = std::max({z0, z1, z2}) < -24 + 1e-6;
    planar += on_top || on_bottom;
    if (!c.own_triangle[static_cast<std::size_t>(t)]) continue;
    top += on_top;
    bottom += on_bottom;
    EXPECT_TRUE(on_top || on_bottom) << "triangle " << t << " at z " << z0;
  }
  EXPECT_GT(top, 0u);
  EXPECT_GT(bottom, 0u);
  EXPECT_EQ(top + bottom, planar);  // every triangle of the two faces, and nothing else
  EXPECT_EQ(c.own_triangles, planar);
  // a box that stops inside the plate (above its bottom) leaves one face: not passed through
  const fe::CutFaces half = fe::detect_cut_faces(fe_test::clip_to_box(part, {19, 24, -12}, {41, 46, 6}));
  EXPECT_EQ(half.own_triangles, 0u);
}

TEST(CutFaces, APlaneClippedAcrossAWholeSideIsCutThereThoughTheRegionHasMuchBorderElsewhere) {
  // NIST FTC-10's first drilled hole (faces 193-194: x 30.7-33.1, y 14.3-27, z -31.2 to -28.8) clipped
  // with the bench's box (its faces' box grown by 0.2 of its diagonal), as from an STL. The box took a
  // pad's corner and the part's face beyond it (y = 23), which crosses the -z side from end to end: 7.7
  // mm, yet only 0.097 of the region's border, most of which runs along -x, +x and +z. That side was
  // taken as surface, the pad's corner there was judged as feature, and the two larger holes, whose
  // surroundings differ, failed the fit (issue 9).
  const fe::TriangleMesh part = fe::read_shape(std::string(FE_REAL_DIR) + "/nist_ftc_10_asme1_rb.stp", fe::tessellation_for_feature(13.2));
  const fe::TriangleMesh ref = fe_test::clip_to_box(part, {28.03, 11.62, -33.87}, {35.77, 29.64, -26.13});
  ASSERT_GT(ref.triangles.rows(), 100);
  const fe::CutFaces c = fe::detect_cut_faces(ref);
  EXPECT_FALSE(c.closed);
  for (int s : {0, 1, 4, 5}) EXPECT_TRUE(c.cut_sides[static_cast<std::size_t>(s)]) << "side " << s;
  EXPECT_FALSE(c.cut_sides[2]);  // nothing crosses -y: the drill point ends in the solid above it
  EXPECT_FALSE(c.cut_sides[3]);  // the pad's top (y = 27) is the highest surface, inside the box
}

TEST(CutFaces, AClosedBoxIsAFeatureNotAllCut) {
  const fe::CutFaces closed = fe::detect_cut_faces(cube(false));
  EXPECT_TRUE(closed.closed);
  EXPECT_EQ(closed.triangles, 0u);  // everything would be cut: a box-like feature is kept whole
  const fe::CutFaces open = fe::detect_cut_faces(cube(true));
  EXPECT_FALSE(open.closed);
  EXPECT_EQ(open.triangles, 0u);
}

TEST(CutFaces, BoxFacesOnThePartWhereTheReferenceWasCutOutOfItAreThePartsOwn) {
  // the rib's box reached below the plate: the plate's bottom inside the box lies on the box's -z
  // side and reaches its other sides, so detect_cut_faces takes it for cut; on the part the
  // reference was cut out of, it lies on the part's surface, the four box sides inside the plate do not
  const fe::TriangleMesh ref = fe::read_shape(models() + "/rib_boxcut_reference.brep");
  const fe::TriangleMesh part = fe::read_shape(models() + "/ribs_bosses.step", fe::tessellation_for_feature(ref.diagonal()));
  const fe::CutFaces c = fe::detect_cut_faces(ref);
  ASSERT_EQ(c.faces.size(), 5u);
  const double h = 0.01 * ref.diagonal();
  const std::vector<char> own = fe::cut_faces_on_target(ref, c, part, h);
  ASSERT_EQ(own.size(), static_cast<std::size_t>(ref.triangles.rows()));
  const double zlo = ref.vertices.col(2).minCoeff();
  std::size_t own_triangles = 0;
  for (Eigen::Index t = 0; t < ref.triangles.rows(); ++t) {
    if (!own[static_cast<std::size_t>(t)]) continue;
    ++own_triangles;
    EXPECT_TRUE(c.cut_triangle[static_cast<std::size_t>(t)]) << t;  // only cut faces are looked at
    for (int k = 0; k < 3; ++k) EXPECT_NEAR(ref.vertices(ref.triangles(t, k), 2), zlo, 1e-6) << "triangle " << t << " is not on the plate's bottom";
  }
  EXPECT_GT(own_triangles, 0u);
  const fe::CutFaces kept = fe::without_own_faces(ref, c, own);
  EXPECT_EQ(kept.faces.size(), 4u);
  EXPECT_EQ(kept.triangles, c.triangles - own_triangles);
  EXPECT_FALSE(kept.cut_sides[4]);  // -z: only the part's own face lay there
  for (int s : {0, 1, 2, 3}) EXPECT_TRUE(kept.cut_sides[static_cast<std::size_t>(s)]) << s;
  // the same reference on the part moved 3 mm: it does not sit there unmoved, nothing is own
  fe::TriangleMesh moved = part;
  moved.vertices.col(0).array() += 3.0;
  const std::vector<char> none = fe::cut_faces_on_target(ref, c, moved, h);
  EXPECT_EQ(std::count(none.begin(), none.end(), 1), 0);
}

TEST(CutFaces, BoxCutReferenceFindsEveryRibAndSaysWhatWasCut) {
  // issue 9: a box-cut reference found 0 of the ribs before its cut faces were set aside
  const fe::Result r = run("rib_boxcut_reference.brep", "ribs_bosses.step");
  EXPECT_TRUE(r.reference_closed);
  // 4 box sides; the plate's bottom, on the box's -z side too, is the part's own face (the
  // reference was cut out of this part: cut_faces_on_target)
  EXPECT_EQ(r.reference_cut_faces.size(), 4u);
  ASSERT_EQ(r.matches.size(), 5u);
  // the truth held in a variable: a range-for over truth()[...] read a destroyed temporary (ASan)
  const auto t = truth();
  for (const auto& rib : t["ribs_bosses.step"]["ribs"]) EXPECT_GE(match_near(r, rib[0], rib[1], 4.0), 0) << "rib " << rib;
  for (const auto& b : t["ribs_bosses.step"]["bosses"]) EXPECT_LT(match_near(r, b[0], b[1], 15.0), 0) << "boss " << b;
  // without looking at the target, the plate's bottom is taken for cut too, and the ribs are found alike
  fe::Params blind;
  blind.cut_faces_on_target = false;
  const fe::Result rb = run("rib_boxcut_reference.brep", "ribs_bosses.step", blind);
  EXPECT_EQ(rb.reference_cut_faces.size(), 5u);
  EXPECT_EQ(rb.matches.size(), 5u);
  // without the detection the same reference finds nothing: the cut faces are what broke it
  fe::Params off;
  off.detect_cut_faces = false;
  EXPECT_LT(run("rib_boxcut_reference.brep", "ribs_bosses.step", off).matches.size(), 3u);
}

TEST(CutFaces, ACornerStepCutOutOfItsBlockKeepsTheBlocksOwnFacesOnTheBox) {
  // A triangular blind step at a block's corner, cut out with a box that reaches past the block on
  // three sides (-x, -y, +z): the block's two sides and top lie on the box there and reach its other
  // sides, so detect_cut_faces takes them for cut, and the step's floor and wall, ending on them,
  // for cut short. On the block itself they lie on the surface: only +x, +y and -z are cut.
  const fe::Result r = run("corner_step_boxcut_reference.brep", "corner_step_block.step");
  EXPECT_TRUE(r.reference_closed);
  EXPECT_EQ(r.reference_cut_faces.size(), 3u);
  EXPECT_EQ(r.reference_own_faces.size(), 3u);
  EXPECT_EQ(r.reference_cut_sides, (std::vector<std::string>{"+x", "+y", "-z"}));
  const auto t = truth();
  for (const auto& c : t["corner_step_block.step"]) EXPECT_GE(match_near(r, c[0], c[1], 6.0), 0) << "step at " << c;
  // without looking at the target all six sides are cut
  fe::Params blind;
  blind.cut_faces_on_target = false;
  const fe::Result rb = run("corner_step_boxcut_reference.brep", "corner_step_block.step", blind);
  EXPECT_EQ(rb.reference_cut_faces.size(), 6u);
  EXPECT_EQ(rb.reference_cut_sides.size(), 6u);
}

TEST(CutFaces, AScaledCornerStepFindsTheBlocksOwnFacesWhereItsMatchesPutIt) {
  // The same corner step, cut out of a block 0.8x as large: it does not sit on this block unmoved,
  // so the block's sides and top on its box are taken for cut (the step's floor and wall alone fit
  // floor-wall corners too). Its matches on the steps put those box faces on the block's surface:
  // they are the part's own, and the search is run again with them kept.
  fe::TriangleMesh ref = fe::read_shape(models() + "/corner_step_boxcut_reference.brep");
  const Eigen::RowVector3d c = 0.5 * (ref.vertices.colwise().minCoeff() + ref.vertices.colwise().maxCoeff());
  ref.vertices = ((ref.vertices.rowwise() - c) * 0.8).rowwise() + c;
  const fe::TriangleMesh part = fe::read_shape(models() + "/corner_step_block.step", fe::tessellation_for_feature(ref.diagonal()));
  const fe::Result r = fe::extract(ref, part, fe::Params{});
  EXPECT_EQ(r.reference_own_faces.size(), 3u);
  EXPECT_EQ(r.reference_cut_sides, (std::vector<std::string>{"+x", "+y", "-z"}));
  const auto t = truth();
  for (const auto& s : t["corner_step_block.step"]) EXPECT_GE(match_near(r, s[0], s[1], 8.0), 0) << "step at " << s;
  EXPECT_TRUE(std::any_of(r.warnings.begin(), r.warnings.end(), [](const std::string& w) { return w.find("where a first search's matches put") != std::string::npos; }));
}

TEST(CutFaces, ClosedStlCutIsDetectedWithoutFaces) {
  const fe::Result r = run("rib_boxcut_reference.stl", "ribs_bosses.step");
  EXPECT_TRUE(r.reference_closed);
  EXPECT_TRUE(r.reference_cut_faces.empty());  // mesh input: triangles only
  EXPECT_GT(r.reference_cut_triangles, 0u);
  EXPECT_EQ(r.matches.size(), 5u);
}

TEST(Mirror, MirroredMeshReflectsAndKeepsNormalsOutward) {
  const fe::TriangleMesh c = cube(false);
  Eigen::Matrix4d M;
  const fe::TriangleMesh m = fe::mirrored_mesh(c, Eigen::Vector3d(2, 0, 0), &M);
  EXPECT_LT((M.topLeftCorner<3, 3>().determinant()), 0);
  for (Eigen::Index i = 0; i < c.vertices.rows(); ++i)
    EXPECT_TRUE(fe::apply_transform(M, c.vertices.row(i).transpose()).isApprox(m.vertices.row(i).transpose()));
  // every triangle's normal still points away from the mirrored cube's center
  const Eigen::Vector3d center = m.vertices.colwise().mean().transpose();
  for (Eigen::Index t = 0; t < m.triangles.rows(); ++t) {
    const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)), b = m.vertices.row(m.triangles(t, 1)), d = m.vertices.row(m.triangles(t, 2));
    EXPECT_GT((b - a).cross(d - a).dot((a + b + d) / 3 - center), 0) << "triangle " << t;
  }
}

TEST(Mirror, SymmetricShapesAreRecognized) {
  // a cube's samples are their own mirror image; an L-shaped pad on a plate is not
  fe::Params p;
  const fe::TriangleMesh c = cube(false);
  const fe::Samples s = fe::sample_surface(c, 0.03, 1);
  EXPECT_TRUE(fe::is_mirror_symmetric(s.points, s.normals, 0.05));
  const fe::TriangleMesh l = fe::read_shape(models() + "/l_pad_reference.brep");
  const fe::Samples ls = fe::sample_surface(l, 0.01 * l.diagonal(), 1);
  EXPECT_FALSE(fe::is_mirror_symmetric(ls.points, ls.normals, 0.02 * l.diagonal()));
}

TEST(Mirror, MirrorImagesAreFoundAndReported) {
  // two L pads and two mirrored ones on one plate, the reference is the first pad's faces
  const auto t = truth()["l_pads.step"];
  const fe::Result r = run("l_pad_reference.brep", "l_pads.step");
  EXPECT_TRUE(r.mirror_searched);
  EXPECT_FALSE(r.reference_mirror_symmetric);
  int found = 0;
  for (const auto& pad : t) {
    const int i = match_near(r, pad["center"][0], pad["center"][1], 5.0);
    if (i < 0) continue;
    ++found;
    const fe::Match& m = r.matches[static_cast<std::size_t>(i)];
    EXPECT_EQ(m.mirrored, pad["mirrored"].get<bool>()) << "pad at " << pad["center"];
    EXPECT_EQ((m.transform.topLeftCorner<3, 3>().determinant() < 0), m.mirrored);
  }
  EXPECT_EQ(found, 4);
  EXPECT_EQ(r.matches.size(), 4u);
  // without the mirrored search the mirrored pads are not found
  fe::Params p;
  p.mirror = false;
  const fe::Result plain = run("l_pad_reference.brep", "l_pads.step", p);
  for (const auto& m : plain.matches) EXPECT_FALSE(m.mirrored);
  EXPECT_LT(match_near(plain, t[2]["center"][0], t[2]["center"][1], 5.0), 0);
  EXPECT_LT(match_near(plain, t[3]["center"][0], t[3]["center"][1], 5.0), 0);
}

TEST(Mirror, TheMirrorImagesSearchSideBySideFindsWhatOneAfterTheOtherFinds) {
  // with two threads the reference's search and its mirror image's run at the same time, one thread
  // each: the same matches to the last bit as one after the other (one thread)
  const fe::TriangleMesh r = fe::read_shape(models() + "/l_pad_reference.brep");
  const fe::TriangleMesh t = fe::read_shape(models() + "/l_pads.step", fe::tessellation_for_feature(r.diagonal()));
  fe::Params two, one;
  two.threads = 2;
  one.threads = 1;
  std::vector<std::string> stages;
  const std::thread::id caller = std::this_thread::get_id();
  bool elsewhere = false;
  const fe::Result a = fe::extract(r, t, two, [&](const std::string& s, double) {
    stages.push_back(s);
    elsewhere = elsewhere || std::this_thread::get_id() != caller;
    return true;
  });
  const fe::Result b = fe::extract(r, t, one);
  ASSERT_TRUE(a.mirror_searched);
  EXPECT_EQ(a.params.threads, 2);
  ASSERT_EQ(a.matches.size(), 4u);
  ASSERT_EQ(a.matches.size(), b.matches.size());
  for (std::size_t i = 0; i < a.matches.size(); ++i) {
    EXPECT_EQ(a.matches[i].transform, b.matches[i].transform) << i;
    EXPECT_EQ(a.matches[i].faces, b.matches[i].faces) << i;
    EXPECT_EQ(a.matches[i].score, b.matches[i].score) << i;
    EXPECT_EQ(a.matches[i].mirrored, b.matches[i].mirrored) << i;
  }
  EXPECT_EQ(a.warnings, b.warnings);
  // every report came from the calling thread (the mirror image's stages passed on by it)
  EXPECT_FALSE(elsewhere);
  ASSERT_GT(stages.size(), 20u);
  // cancelled at any point, the search stops with Cancelled (the mirror image's thread with it).
  // The points are counted in the reference's own search, up to its last report ("done"): after it
  // this thread passes on the mirror search's stages every 50 ms, as many as it takes, so a count
  // past it may never be reached (CI, on a busy machine: 233 reports, then fewer than 230).
  const std::size_t own = static_cast<std::size_t>(std::find(stages.begin(), stages.end(), "done") - stages.begin()) + 1;
  ASSERT_LE(own, stages.size());
  ASSERT_GT(own, 20u);
  for (const std::size_t at : {std::size_t{3}, own / 2, own}) {
    std::size_t calls = 0;
    EXPECT_THROW(fe::extract(r, t, two, [&](const std::string&, double) { return ++calls < at; }), fe::Cancelled) << at;
  }
}

TEST(Creases, SharpEdgesAndCornersOfACube) {
  // the quadric fit sees planes; the crease rule sees convex edges (ridges) and corners (caps)
  const fe::TriangleMesh c = cube(false);
  const fe::Samples s = fe::sample_surface(c, 0.02, 1);
  fe::Samples q;
  q.points.resize(3, 3);
  q.normals.resize(3, 3);
  q.points << 0.5, 0.5, 1.0,  // middle of the top face
      0.5, 0.02, 1.0,         // near the top face's edge y = 0
      0.03, 0.03, 1.0;        // near the corner (0, 0, 1)
  q.normals << 0, 0, 1, 0, 0, 1, 0, 0, 1;
  const Eigen::VectorXd si = fe::crease_shape_index(s, q, 0.08);
  EXPECT_TRUE(std::isnan(si(0)));
  EXPECT_DOUBLE_EQ(si(1), 0.75);
  EXPECT_DOUBLE_EQ(si(2), 1.0);
  // inside the open cube, seen from within: the same places are concave (rut, cup)
  fe::TriangleMesh inside = cube(false);
  inside.triangles.col(1).swap(inside.triangles.col(2));
  const fe::Samples si_s = fe::sample_surface(inside, 0.02, 1);
  fe::Samples qi = q;
  qi.normals *= -1;
  const Eigen::VectorXd sii = fe::crease_shape_index(si_s, qi, 0.08);
  EXPECT_DOUBLE_EQ(sii(1), 0.25);
  EXPECT_DOUBLE_EQ(sii(2), 0.0);
  EXPECT_TRUE(fe::is_key_shape_index(fe::kCreaseShapeIndex + 1.0, 0.07));
  EXPECT_FALSE(fe::is_key_shape_index(fe::kCreaseShapeIndex + 0.75, 0.07));
}

TEST(Creases, PlanarMachinedFeatureIsSearchable) {
  // the L pad is all planes with sharp edges: it used to be refused ("no distinctive key points");
  // a single plane still is (EndToEnd.PlanarReferenceIsRefused)
  const fe::Result r = run("l_pad_reference.brep", "l_pads.step");
  EXPECT_GT(r.reference.key_points, 5u);
  EXPECT_FALSE(r.matches.empty());
}

TEST(Mirror, MeshOnAMirroredInstanceKeepsItsNormalsOutward) {
  // the boss feature's FE mesh placed by a reflection onto the mirrored boss: element order reversed,
  // nothing inverted (without the reversal every shell would count as inverted)
  const fe::FeatureModel feature = fe::read_feature(std::string(FE_FEATURES_DIR) + "/boss");
  const fe::TriangleMesh geometry = fe::read_shape(feature.geometry_path);
  Eigen::Matrix4d M;
  const Eigen::Vector3d c = 0.5 * (geometry.vertices.colwise().minCoeff() + geometry.vertices.colwise().maxCoeff()).transpose();
  const fe::TriangleMesh target = fe::mirrored_mesh(geometry, c + Eigen::Vector3d(3, 0, 0), &M);
  const fe::TransferredMesh t = fe::transfer_mesh(feature.mesh, M, target);
  EXPECT_TRUE(t.reversed);
  EXPECT_EQ(t.after_summary.inverted, 0u);
  EXPECT_TRUE(t.invalid_elements.empty());
  EXPECT_EQ(t.unprojected, 0u);
  const fe::TransferredMesh same = fe::transfer_mesh(feature.mesh, Eigen::Matrix4d::Identity(), geometry);
  EXPECT_FALSE(same.reversed);
  EXPECT_EQ(same.after_summary.inverted, 0u);
}
