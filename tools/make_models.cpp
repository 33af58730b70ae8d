// fe_make_models OUTDIR [--bench]
// Generates the test and example models with OpenCASCADE, plus ground truth (truth.json):
//   rib_reference.step      the reference feature: faces of one filleted rib (an open shell)
//   rib_wide_reference.brep the faces of the second rib of ribs_bosses.step, cut from the plate
//   scaled_ribs.step        plate with 5 copies of the rib scaled 1.0, 1.2, 1.4, 1.6, 1.8
//   ribs_bosses.step        plate with 5 ribs of different top/bottom widths and 2 filleted bosses
//   ribs_bosses_cracked.stl (b) tessellated, unwelded, each face shifted (cracks) and jittered
//   ribs_bosses_rotated.step (b) rotated arbitrarily in 3D
//   flat_reference.step     a planar patch (no distinctive key points)
//   boss_only.step          a plate with bosses only (nothing similar to the rib)
//   bench_100k.stl          (--bench) a larger plate of ribs and bosses, about 100k triangles
//   suite/                  (--suite) the benchmark suite: models as STEP and STL, suite.json with the
//                           cases and their ground truth (target FaceN sets and boxes per instance)
//                           (--real DIR: plus a case on the real part DIR/nist_ftc_10_asme1_rb.stp)
//   scaling/                (--scaling) that plate tessellated to about 10k, 100k, 300k and 1M triangles
// Units are millimetres. Everything is deterministic.
#include "featureextract/io.h"

#include <nlohmann/json.hpp>

#include <BRepAlgoAPI_Common.hxx>
#include <BRepAlgoAPI_Cut.hxx>
#include <BRepAlgoAPI_Fuse.hxx>
#include <BRepBuilderAPI_MakePolygon.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_GTransform.hxx>
#include <BRepBuilderAPI_Transform.hxx>
#include <BRepPrimAPI_MakeSphere.hxx>
#include <gp_GTrsf.hxx>
#include <BRepBndLib.hxx>
#include <BRepFilletAPI_MakeFillet.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepPrimAPI_MakeBox.hxx>
#include <BRepPrimAPI_MakeCylinder.hxx>
#include <BRepPrimAPI_MakePrism.hxx>
#include <BRepTools.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <Interface_Static.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_PrinterOStream.hxx>
#include <Poly_Triangulation.hxx>
#include <STEPControl_Reader.hxx>
#include <STEPControl_Writer.hxx>
#include <TopExp.hxx>
#include <TopExp_Explorer.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Compound.hxx>
#include <gp_Ax2.hxx>
#include <gp_Trsf.hxx>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>
#include <tuple>
#include <vector>

namespace {

struct Rib {
  double x, y;        // footprint center on the plate top (z = 0)
  double length = 40; // along y
  double wb = 8, wt = 5, h = 12;
  double scale = 1;   // isotropic scale of the whole rib (fillets too)
  double r_top = 1.2, r_root = 1.5;
  double angle = 0;   // rotation about the vertical axis through (x, y), degrees
};
struct Boss {
  double x, y, r = 6, h = 12, r_top = 1.0, r_root = 1.5;
};

struct Box {
  double x0, y0, z0, x1, y1, z1;
};
Box bbox(const TopoDS_Shape& s) {
  Bnd_Box b;
  BRepBndLib::Add(s, b);
  Box r;
  b.Get(r.x0, r.y0, r.z0, r.x1, r.y1, r.z1);
  return r;
}

// The faces of the counterbored hole at (30, 35) of a 24 mm plate (top at z = 0), as a user picks
// them: those inside the hole's box, but not the plate's top or bottom. Written as a BREP compound.
void write_first_hole(const TopoDS_Shape& plate, const std::string& path) {
  TopoDS_Compound picked;
  BRep_Builder bb;
  bb.MakeCompound(picked);
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(plate, TopAbs_FACE, faces);
  for (int i = 1; i <= faces.Extent(); ++i) {
    const auto [a0, b0, c0, a1, b1, c1] = bbox(faces(i));
    if (a0 < 22 || a1 > 38 || b0 < 27 || b1 > 43) continue;  // not the first hole's
    if (c1 - c0 < 1e-6 && (std::abs(c1) < 1e-3 || std::abs(c1 + 24) < 1e-3)) continue;  // the plate's top or bottom
    bb.Add(picked, faces(i));
  }
  BRepTools::Write(picked, path.c_str());
}

[[noreturn]] void die(const std::string& m) {
  std::cerr << "fe_make_models: " << m << "\n";
  std::exit(1);
}

TopoDS_Shape read_step(const std::string& path) {
  STEPControl_Reader r;
  if (r.ReadFile(path.c_str()) != IFSelect_RetDone || r.TransferRoots() == 0) die(path + ": cannot read STEP");
  return r.OneShape();
}

TopoDS_Shape rib_solid(const Rib& r) {
  const double s = r.scale, wb = r.wb * s, wt = r.wt * s, h = r.h * s, len = r.length * s;
  // trapezoid in the XZ plane, slightly below z = 0 so the fuse with the plate is clean
  BRepBuilderAPI_MakePolygon poly;
  poly.Add(gp_Pnt(-wb / 2, -len / 2, -0.5));
  poly.Add(gp_Pnt(wb / 2, -len / 2, -0.5));
  poly.Add(gp_Pnt(wt / 2, -len / 2, h));
  poly.Add(gp_Pnt(-wt / 2, -len / 2, h));
  poly.Close();
  TopoDS_Face f = BRepBuilderAPI_MakeFace(poly.Wire());
  TopoDS_Shape prism = BRepPrimAPI_MakePrism(f, gp_Vec(0, len, 0));
  // fillet the top edges and the vertical end edges (everything above z = 0)
  BRepFilletAPI_MakeFillet fil(prism);
  for (TopExp_Explorer e(prism, TopAbs_EDGE); e.More(); e.Next()) {
    const auto [x0, y0, z0, x1, y1, z1] = bbox(e.Current());
    if (z0 > 0.0) fil.Add(r.r_top * s, TopoDS::Edge(e.Current()));                    // top edges
    else if (z1 > h * 0.5 && std::abs(y1 - y0) < 1e-3) fil.Add(r.r_top * s, TopoDS::Edge(e.Current()));  // end edges
  }
  fil.Build();
  if (!fil.IsDone()) die("rib fillet failed");
  gp_Trsf t, rot;
  t.SetTranslation(gp_Vec(r.x, r.y, 0));
  rot.SetRotation(gp_Ax1(gp::Origin(), gp::DZ()), r.angle * M_PI / 180.0);
  return BRepBuilderAPI_Transform(fil.Shape(), t * rot, true).Shape();
}

TopoDS_Shape boss_solid(const Boss& b) {
  TopoDS_Shape c = BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(b.x, b.y, -0.5), gp::DZ()), b.r, b.h + 0.5).Shape();
  BRepFilletAPI_MakeFillet fil(c);
  for (TopExp_Explorer e(c, TopAbs_EDGE); e.More(); e.Next()) {
    if (bbox(e.Current()).z0 > b.h - 1e-3) fil.Add(b.r_top, TopoDS::Edge(e.Current()));
  }
  fil.Build();
  if (!fil.IsDone()) die("boss fillet failed");
  return fil.Shape();
}

// Plate (top at z = 0) with ribs and bosses fused on, root edges filleted.
TopoDS_Shape part(double sx, double sy, const std::vector<Rib>& ribs, const std::vector<Boss>& bosses,
                  const std::vector<TopoDS_Shape>& extra = {}) {
  TopoDS_Shape s = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, -6), gp_Pnt(sx, sy, 0)).Shape();
  for (const Rib& r : ribs) s = BRepAlgoAPI_Fuse(s, rib_solid(r)).Shape();
  for (const Boss& b : bosses) s = BRepAlgoAPI_Fuse(s, boss_solid(b)).Shape();
  for (const TopoDS_Shape& e : extra) s = BRepAlgoAPI_Fuse(s, e).Shape();
  // root fillets: edges lying in z = 0 that are not on the plate's outer boundary
  BRepFilletAPI_MakeFillet fil(s);
  int n = 0;
  for (TopExp_Explorer e(s, TopAbs_EDGE); e.More(); e.Next()) {
    const auto [x0, y0, z0, x1, y1, z1] = bbox(e.Current());
    const bool at_top = std::abs(z0) < 1e-4 && std::abs(z1) < 1e-4;
    const bool boundary = x0 < 1e-4 || y0 < 1e-4 || x1 > sx - 1e-4 || y1 > sy - 1e-4;
    if (!at_top || boundary) continue;
    double rr = 1.5;
    for (const Rib& r : ribs)
      if (r.angle == 0 ? std::abs(0.5 * (x0 + x1) - r.x) < r.wb * r.scale && std::abs(0.5 * (y0 + y1) - r.y) < r.length * r.scale
                       : std::hypot(0.5 * (x0 + x1) - r.x, 0.5 * (y0 + y1) - r.y) < (0.6 * r.length + r.wb) * r.scale)
        rr = r.r_root * r.scale;
    fil.Add(rr, TopoDS::Edge(e.Current()));
    ++n;
  }
  if (n > 0) {
    fil.Build();
    if (!fil.IsDone()) die("root fillet failed");
    s = fil.Shape();
  }
  return s;
}

void write_step(const TopoDS_Shape& s, const std::string& path) {
  STEPControl_Writer w;
  Interface_Static::SetCVal("write.step.schema", "AP214IS");
  if (w.Transfer(s, STEPControl_AsIs) != IFSelect_RetDone) die("STEP transfer failed for " + path);
  if (w.Write(path.c_str()) != IFSelect_RetDone) die("STEP write failed for " + path);
}

// The reference feature: the faces of the part that lie on or above the plate top (z >= 0) within
// the given box: the rib's faces and its root fillets, as a compound of faces (an open shell).
TopoDS_Shape cut_faces(const TopoDS_Shape& s, double x0, double y0, double x1, double y1) {
  TopoDS_Compound c;
  BRep_Builder b;
  b.MakeCompound(c);
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(s, TopAbs_FACE, faces);
  int n = 0;
  for (int i = 1; i <= faces.Extent(); ++i) {
    const auto [a0, b0, c0, a1, b1, c1] = bbox(faces(i));
    if (c1 < 1e-3) continue;  // plate top and bottom
    if (c0 < -1e-3) continue; // plate sides
    if (a0 < x0 || a1 > x1 || b0 < y0 || b1 > y1) continue;
    b.Add(c, faces(i));
    ++n;
  }
  if (n == 0) die("reference cut found no faces");
  return c;
}

fe::TriangleMesh tessellate(const TopoDS_Shape& s, double defl, double angle = 0.2) {
  BRepMesh_IncrementalMesh(s, defl, false, angle, true);
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(s, TopAbs_FACE, faces);
  std::vector<double> v;
  std::vector<int> t, f;
  for (int i = 1; i <= faces.Extent(); ++i) {
    TopLoc_Location loc;
    Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(TopoDS::Face(faces(i)), loc);
    if (tri.IsNull()) continue;
    const int base = static_cast<int>(v.size() / 3);
    for (int k = 1; k <= tri->NbNodes(); ++k) {
      const gp_Pnt p = tri->Node(k).Transformed(loc.Transformation());
      v.insert(v.end(), {p.X(), p.Y(), p.Z()});
    }
    const bool rev = faces(i).Orientation() == TopAbs_REVERSED;
    for (int k = 1; k <= tri->NbTriangles(); ++k) {
      int a, b, c;
      tri->Triangle(k).Get(a, b, c);
      if (rev) std::swap(b, c);
      t.insert(t.end(), {base + a - 1, base + b - 1, base + c - 1});
      f.push_back(i);
    }
  }
  fe::TriangleMesh m;
  m.vertices = Eigen::Map<fe::Points>(v.data(), static_cast<Eigen::Index>(v.size() / 3), 3);
  m.triangles = Eigen::Map<fe::Triangles>(t.data(), static_cast<Eigen::Index>(t.size() / 3), 3);
  m.face_ids = Eigen::Map<Eigen::VectorXi>(f.data(), static_cast<Eigen::Index>(f.size()));
  m.num_faces = faces.Extent();
  return m;
}

// Unweld (every triangle its own vertices), shift each B-rep face by a small random offset (cracks
// between faces) and jitter every vertex.
fe::TriangleMesh damage(const fe::TriangleMesh& m, double crack, double jitter, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  std::vector<Eigen::Vector3d> face_shift(static_cast<std::size_t>(m.num_faces + 1));
  for (auto& s : face_shift) s = Eigen::Vector3d(g(rng), g(rng), g(rng)).normalized() * crack;
  fe::TriangleMesh out;
  out.vertices.resize(3 * m.triangles.rows(), 3);
  out.triangles.resize(m.triangles.rows(), 3);
  out.face_ids = Eigen::VectorXi::Zero(m.triangles.rows());
  for (Eigen::Index t = 0; t < m.triangles.rows(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d j(g(rng), g(rng), g(rng));
      out.vertices.row(3 * t + k) = m.vertices.row(m.triangles(t, k)) + (face_shift[static_cast<std::size_t>(m.face_ids(t))] + jitter * j).transpose();
      out.triangles(t, k) = static_cast<int>(3 * t + k);
    }
  return out;
}

std::string json_point(double x, double y, double z) {
  std::ostringstream s;
  s << "[" << x << ", " << y << ", " << z << "]";
  return s.str();
}


// ---------------------------------------------------------------------------------------------
// The benchmark suite (issue 4): cases with ground truth per instance (target FaceN sets and boxes).

using Json = nlohmann::ordered_json;

// FaceN of the faces of s on or above the plate top (not the plate top itself, not the plate sides)
// whose bounding box lies inside the xy box: the feature standing there, root fillets included.
std::vector<int> faces_in(const TopoDS_Shape& s, double x0, double y0, double x1, double y1) {
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(s, TopAbs_FACE, faces);
  std::vector<int> out;
  for (int i = 1; i <= faces.Extent(); ++i) {
    Bnd_Box fb;  // exact box of the surface (no triangulation, no tolerance gap)
    BRepBndLib::AddOptimal(faces(i), fb, false, false);
    double a0, b0, c0, a1, b1, c1;
    fb.Get(a0, b0, c0, a1, b1, c1);
    if (c1 < 0.05 || c0 < -0.05) continue;
    if (a0 < x0 || a1 > x1 || b0 < y0 || b1 > y1) continue;
    out.push_back(i);
  }
  return out;
}

Json instance(const TopoDS_Shape& s, const std::vector<int>& faces, const Box& region, const std::string& label) {
  if (faces.empty()) die("suite: no truth faces for " + label);
  TopTools_IndexedMapOfShape map;
  TopExp::MapShapes(s, TopAbs_FACE, map);
  Bnd_Box b;
  for (int f : faces) BRepBndLib::Add(map(f), b);
  double x0, y0, z0, x1, y1, z1;
  b.Get(x0, y0, z0, x1, y1, z1);
  (void)region;
  return {{"label", label}, {"faces", faces}, {"box", {{x0, y0, z0}, {x1, y1, z1}}}};
}

TopoDS_Shape gtransform(const TopoDS_Shape& s, const gp_Mat& m) {
  gp_GTrsf g;
  g.SetVectorialPart(m);
  BRepBuilderAPI_GTransform t(s, g, true);
  if (!t.IsDone()) die("suite: general transform failed");
  return t.Shape();
}

TopoDS_Shape moved(const TopoDS_Shape& s, double dx, double dy) {
  gp_Trsf t;
  t.SetTranslation(gp_Vec(dx, dy, 0));
  return BRepBuilderAPI_Transform(s, t, true).Shape();
}

TopoDS_Compound compound(const std::vector<TopoDS_Shape>& parts) {
  TopoDS_Compound c;
  BRep_Builder b;
  b.MakeCompound(c);
  for (const TopoDS_Shape& p : parts) b.Add(c, p);
  return c;
}

// A row (or grid) of tiles: each a small plate with one rib (scale s) deformed by m, laid out with gaps.
struct Tile {
  double scale = 1;
  gp_Mat m = gp_Mat(1, 0, 0, 0, 1, 0, 0, 0, 1);
  std::string label;
  int row = 0;
};
std::pair<TopoDS_Shape, Json> tiles(const std::vector<Tile>& spec) {
  std::vector<TopoDS_Shape> parts;
  std::vector<Box> boxes;
  double x = 0, y = 0, row_h = 0;
  int row = spec.empty() ? 0 : spec[0].row;
  for (const Tile& t : spec) {
    if (t.row != row) {
      row = t.row;
      x = 0;
      y += row_h + 10;
      row_h = 0;
    }
    Rib r{18 * t.scale, 32 * t.scale};
    r.scale = t.scale;
    TopoDS_Shape p = gtransform(part(36 * t.scale, 64 * t.scale, {r}, {}), t.m);
    const Box b0 = bbox(p);
    p = moved(p, x - b0.x0, y - b0.y0);
    const Box b = bbox(p);
    parts.push_back(p);
    boxes.push_back(b);
    x = b.x1 + 10;
    row_h = std::max(row_h, b.y1 - b.y0);
  }
  const TopoDS_Compound c = compound(parts);
  Json truth = Json::array();
  for (std::size_t i = 0; i < spec.size(); ++i) {
    const Box& b = boxes[i];
    truth.push_back(instance(c, faces_in(c, b.x0 - 1e-3, b.y0 - 1e-3, b.x1 + 1e-3, b.y1 + 1e-3), b, spec[i].label));
  }
  return {c, truth};
}

// FaceN of the faces of s lying wholly inside a 3D box (exact surface boxes).
std::vector<int> faces_in_box(const TopoDS_Shape& s, const Box& box) {
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(s, TopAbs_FACE, faces);
  std::vector<int> out;
  for (int i = 1; i <= faces.Extent(); ++i) {
    Bnd_Box fb;
    BRepBndLib::AddOptimal(faces(i), fb, false, false);
    double a0, b0, c0, a1, b1, c1;
    fb.Get(a0, b0, c0, a1, b1, c1);
    if (a0 >= box.x0 && a1 <= box.x1 && b0 >= box.y0 && b1 <= box.y1 && c0 >= box.z0 && c1 <= box.z1) out.push_back(i);
  }
  return out;
}

TopoDS_Compound faces_compound(const TopoDS_Shape& s, const std::vector<int>& ids) {
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(s, TopAbs_FACE, faces);
  std::vector<TopoDS_Shape> v;
  for (int i : ids) v.push_back(faces(i));
  return compound(v);
}

void write_suite(const std::string& root, const TopoDS_Shape& b, const std::vector<Rib>& ribs_b, const std::string& real_dir) {
  const std::string dir = root + "/suite";
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) die(dir + ": cannot create folder: " + ec.message());
  Json cases = Json::array();
  // every model as STEP (FaceN ground truth) and as an STL of the same geometry (for mesh-only peers)
  auto save = [&](const std::string& name, const TopoDS_Shape& s) {
    write_step(s, dir + "/" + name + ".step");
    fe::write_stl(tessellate(s, 0.05), dir + "/" + name + ".stl", true);
    std::cout << "fe_make_models: suite/" << name << "\n" << std::flush;
  };
  auto add = [&](const std::string& name, const std::string& what, const std::string& ref, const std::string& target,
                 const Json& truth, const std::string& kind) {
    cases.push_back({{"name", name}, {"what", what}, {"kind", kind}, {"reference", ref}, {"target", target},
                     {"instances", truth}});
  };
  {
    Rib r{30, 40};
    save("rib_reference", cut_faces(part(60, 80, {r}, {}), 15, 10, 45, 70));
    save("boss_reference", cut_faces(part(60, 60, {}, {{30, 30}}), 15, 15, 45, 45));
    save("rib_wide_reference", cut_faces(b, 60 - 15, 40 - 30, 60 + 15, 40 + 30));
  }
  auto rib_truth = [&](const TopoDS_Shape& s, const std::vector<Rib>& ribs, double half_x, double half_y) {
    Json t = Json::array();
    for (const Rib& r : ribs) {
      const Box box{r.x - half_x, r.y - half_y, -1, r.x + half_x, r.y + half_y, 1};
      std::ostringstream l;
      l << "rib at (" << r.x << ", " << r.y << ")";
      t.push_back(instance(s, faces_in(s, box.x0, box.y0, box.x1, box.y1), box, l.str()));
    }
    return t;
  };
  // isotropic scale sweep 1.0 - 3.0
  {
    std::vector<Tile> spec;
    for (int i = 0; i <= 8; ++i) {
      Tile t;
      t.scale = 1.0 + 0.25 * i;
      t.label = "scale " + std::to_string(t.scale).substr(0, 4);
      t.row = i / 5;
      spec.push_back(t);
    }
    auto [s, truth] = tiles(spec);
    save("iso_scale", s);
    add("iso_scale", "9 ribs scaled 1.0x to 3.0x (paper: up to 1.8x)", "rib_reference", "iso_scale", truth, "scale");
  }
  // anisotropic: width x length grid up to 2.5x
  {
    std::vector<Tile> spec;
    const double f[] = {1.0, 1.5, 2.0, 2.5};
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 4; ++j) {
        Tile t;
        t.m = gp_Mat(f[j], 0, 0, 0, f[i], 0, 0, 0, 1);
        t.label = "width " + std::to_string(f[j]).substr(0, 3) + " x length " + std::to_string(f[i]).substr(0, 3);
        t.row = i;
        spec.push_back(t);
      }
    auto [s, truth] = tiles(spec);
    save("aniso_grid", s);
    add("aniso_grid", "16 ribs stretched: width x length factors 1.0-2.5 (paper: 1.5 x 1.2)", "rib_reference", "aniso_grid",
        truth, "anisotropic");
  }
  // a development counterpart of aniso_grid (held-out): other width x length factors, some below
  // 1, and four tiles stretched in height too (the plate's thickness with it)
  {
    std::vector<Tile> spec;
    // the first tile is the one the user-style cases take their reference from
    const double m[][3] = {{1.2, 1.1, 1},   {0.7, 0.8, 1},   {1.8, 1.0, 1},   {2.2, 1.3, 1},
                           {0.8, 1.6, 1},   {1.4, 2.0, 1},   {1.9, 2.4, 1},   {2.6, 2.6, 1},
                           {1.2, 1.1, 1.6}, {1.6, 1.0, 0.7}, {1.0, 2.1, 1.4}, {2.1, 1.6, 0.8}};
    for (int i = 0; i < 12; ++i) {
      Tile t;
      t.m = gp_Mat(m[i][0], 0, 0, 0, m[i][1], 0, 0, 0, m[i][2]);
      std::ostringstream l;
      l << "width " << m[i][0] << " x length " << m[i][1] << " x height " << m[i][2];
      t.label = l.str();
      t.row = i / 4;
      spec.push_back(t);
    }
    auto [s, truth] = tiles(spec);
    save("stretched_ribs", s);
    add("stretched_ribs", "12 ribs stretched per axis: width 0.7-2.6, length 0.8-2.6, height 0.7-1.6 (development)",
        "rib_reference", "stretched_ribs", truth, "anisotropic");
  }
  // shear: leaning (x += k z) and skewed in plane (x += k y)
  {
    std::vector<Tile> spec;
    for (double k : {0.2, 0.4}) {
      Tile t;
      t.m = gp_Mat(1, 0, k, 0, 1, 0, 0, 0, 1);
      t.label = "lean " + std::to_string(k).substr(0, 3);
      spec.push_back(t);
    }
    for (double k : {0.3, 0.6}) {
      Tile t;
      t.m = gp_Mat(1, k, 0, 0, 1, 0, 0, 0, 1);
      t.label = "skew " + std::to_string(k).substr(0, 3);
      spec.push_back(t);
    }
    auto [s, truth] = tiles(spec);
    save("shear", s);
    add("shear", "4 ribs sheared: leaning 0.2, 0.4 (x += k z), skewed in plane 0.3, 0.6 (x += k y)", "rib_reference", "shear",
        truth, "anisotropic");
  }
  // the paper's plate: 5 ribs of different top/bottom widths, 2 bosses that must not match
  const Json truth_b = rib_truth(b, ribs_b, 15, 30);
  save("five_ribs", b);
  add("five_ribs", "5 ribs of different top/bottom widths, 2 bosses (distractors)", "rib_reference", "five_ribs", truth_b, "paper");
  // axisymmetric bosses of 5 sizes, no dummy shape
  {
    std::vector<Boss> bosses;
    const double r[] = {4, 5, 6, 7.5, 9}, h[] = {8, 10, 12, 14, 16};
    double x = 20;
    for (int i = 0; i < 5; ++i) {
      bosses.push_back({x, 35, r[i], h[i]});
      x += 2 * r[i] + 30;
    }
    const TopoDS_Shape s = part(x, 70, {}, bosses);
    Json truth = Json::array();
    for (const Boss& bo : bosses) {
      const double m = bo.r + 3;
      truth.push_back(instance(s, faces_in(s, bo.x - m, bo.y - m, bo.x + m, bo.y + m), {}, "boss r " + std::to_string(bo.r).substr(0, 3)));
    }
    save("bosses", s);
    add("bosses", "5 cylindrical bosses, radius 4-9 mm, height 8-16 mm, no dummy shape (paper: 4 of 5 with a dummy)",
        "boss_reference", "bosses", truth, "axisymmetric");
  }
  // a cast-like part (the plate of five_ribs) stretched anisotropically, reference cut from the original
  {
    const double ax = 1.3, ay = 0.85, az = 1.15;
    const TopoDS_Shape s = gtransform(b, gp_Mat(ax, 0, 0, 0, ay, 0, 0, 0, az));
    Json truth = Json::array();
    for (const Rib& r : ribs_b)
      truth.push_back(instance(s, faces_in(s, ax * (r.x - 15), ay * (r.y - 30), ax * (r.x + 15), ay * (r.y + 30)), {},
                               "rib at x " + std::to_string(static_cast<int>(ax * r.x))));
    save("cast_aniso", s);
    add("cast_aniso", "the five_ribs part stretched 1.3 x 0.85 x 1.15; reference cut from the unstretched part",
        "rib_wide_reference", "cast_aniso", truth, "anisotropic");
  }
  // six similar features: ribs of different lengths, heights and widths
  {
    std::vector<Rib> ribs;
    const double len[] = {40, 30, 50, 40, 60, 35}, h[] = {12, 10, 14, 9, 12, 16}, wb[] = {8, 8, 9, 7, 8, 8};
    for (int i = 0; i < 6; ++i) {
      Rib r{25.0 + 45.0 * i, 50};
      r.length = len[i];
      r.h = h[i];
      r.wb = wb[i];
      ribs.push_back(r);
    }
    const TopoDS_Shape s = part(285, 100, ribs, {});
    Json truth = Json::array();
    for (const Rib& r : ribs)
      truth.push_back(instance(s, faces_in(s, r.x - 15, r.y - r.length / 2 - 8, r.x + 15, r.y + r.length / 2 + 8), {},
                               "rib length " + std::to_string(static_cast<int>(r.length)) + " height " + std::to_string(static_cast<int>(r.h))));
    save("six_features", s);
    add("six_features", "6 ribs of lengths 30-60 mm, heights 9-16 mm, base widths 7-9 mm", "rib_reference", "six_features",
        truth, "paper");
  }
  // features rotated in the plane
  {
    std::vector<Rib> ribs;
    const double angle[] = {0, 30, 60, 90, 135};
    for (int i = 0; i < 5; ++i) {
      Rib r{35.0 + 55.0 * i, 45};
      r.angle = angle[i];
      ribs.push_back(r);
    }
    const TopoDS_Shape s = part(290, 90, ribs, {});
    Json truth = Json::array();
    for (const Rib& r : ribs)
      truth.push_back(instance(s, faces_in(s, r.x - 27, r.y - 27, r.x + 27, r.y + 27), {},
                               "rib turned " + std::to_string(static_cast<int>(r.angle)) + " deg"));
    save("rotated_in_plane", s);
    add("rotated_in_plane", "5 ribs turned 0, 30, 60, 90, 135 degrees in the plate plane", "rib_reference",
        "rotated_in_plane", truth, "rotation");
  }
  // the whole part rotated in 3D (a transformed copy keeps the face order)
  {
    gp_Trsf t;
    t.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(1, 2, 3)), 0.9);
    const TopoDS_Shape s = BRepBuilderAPI_Transform(b, t, true).Shape();
    Json truth = Json::array();
    for (const auto& inst : truth_b) truth.push_back(instance(s, inst["faces"].get<std::vector<int>>(), {}, inst["label"].get<std::string>()));
    save("rotated_3d", s);
    add("rotated_3d", "the five_ribs part rotated 0.9 rad about (1, 2, 3)", "rib_reference", "rotated_3d", truth, "rotation");
  }
  // distractors: 3 ribs among a block, a boss, a dome and a low pad
  {
    std::vector<Rib> ribs = {{30, 45}, {110, 45}, {190, 45}};
    std::vector<TopoDS_Shape> extra;
    extra.push_back(BRepPrimAPI_MakeBox(gp_Pnt(62, 15, -0.5), gp_Pnt(78, 30, 10)).Shape());
    extra.push_back(BRepPrimAPI_MakeSphere(gp_Pnt(70, 68, -4), 11).Shape());
    extra.push_back(BRepPrimAPI_MakeBox(gp_Pnt(140, 60, -0.5), gp_Pnt(162, 74, 4)).Shape());
    const TopoDS_Shape s = part(220, 90, ribs, {{150, 25}}, extra);
    save("distractors", s);
    add("distractors", "3 ribs and 4 distractors (sharp block, boss, dome, low pad)", "rib_reference", "distractors",
        rib_truth(s, ribs, 15, 30), "distractor");
  }
  // nothing similar
  {
    save("nothing", part(120, 80, {}, {{30, 40}, {90, 40, 8, 10}}));
    add("nothing", "bosses only: nothing similar to the rib", "rib_reference", "nothing", Json::array(), "distractor");
  }
  // cracked, jittered, unwelded mesh of five_ribs: mesh input, truth as boxes only
  {
    fe::write_stl(damage(tessellate(b, 0.05), 0.03, 0.01, 7), dir + "/cracked.stl", true);
    Json truth = Json::array();
    for (const auto& inst : truth_b) truth.push_back({{"label", inst["label"]}, {"faces", Json::array()}, {"box", inst["box"]}});
    cases.push_back({{"name", "cracked"}, {"what", "five_ribs as a cracked (0.03 mm), jittered (0.01 mm), unwelded STL"},
                     {"kind", "mesh"}, {"reference", "rib_reference"}, {"target", "cracked"}, {"target_is_mesh", true},
                     {"instances", truth}});
  }
  // a real part: NIST FTC-10 (public domain, ../shared/data/real), one corner ear cut out as the
  // reference, the four ears (mirror images two by two) as the truth
  if (!real_dir.empty()) {
    const std::string path = real_dir + "/nist_ftc_10_asme1_rb.stp";
    const TopoDS_Shape s = read_step(path);
    const Box ears[] = {{-81, -1, 18, -60, 33, 39}, {60, -1, 18, 81, 33, 39}, {-81, -1, -39, -60, 33, -18}, {60, -1, -39, 81, 33, -18}};
    const std::string names[] = {"ear x-, z+ (the reference)", "ear x+, z+", "ear x-, z-", "ear x+, z-"};
    Json truth = Json::array();
    for (int i = 0; i < 4; ++i) truth.push_back(instance(s, faces_in_box(s, ears[i]), ears[i], names[i]));
    save("ftc10_ear_reference", faces_compound(s, faces_in_box(s, ears[0])));
    {
      // the same ear cut out with a box, as a user (and the paper) cuts a reference: the ear's faces'
      // bounding box grown by 20 % of its diagonal, so it takes some of the housing around the ear
      // too, which is not the same around every ear
      Bnd_Box eb;
      BRepBndLib::AddOptimal(faces_compound(s, faces_in_box(s, ears[0])), eb, false, false);
      double x0, y0, z0, x1, y1, z1;
      eb.Get(x0, y0, z0, x1, y1, z1);
      const double m = 0.2 * std::sqrt((x1 - x0) * (x1 - x0) + (y1 - y0) * (y1 - y0) + (z1 - z0) * (z1 - z0));
      BRepAlgoAPI_Common common(s, BRepPrimAPI_MakeBox(gp_Pnt(x0 - m, y0 - m, z0 - m), gp_Pnt(x1 + m, y1 + m, z1 + m)).Shape());
      if (!common.IsDone()) die("box cut of the FTC-10 ear failed");
      BRepTools::Write(common.Shape(), (dir + "/ftc10_ear_boxcut_reference.brep").c_str());
    }
    save("ftc10", s);
    add("ftc10", "real part NIST FTC-10 (214 faces): its 4 corner ears, reference cut from one of them", "ftc10_ear_reference",
        "ftc10", truth, "real");
  }
  // a second real part: NIST FTC-06, four identical cylindrical bosses (radius 22.2 mm, with
  // counterbored holes), one of them as the reference
  if (!real_dir.empty()) {
    const std::string path = real_dir + "/nist_ftc_06_asme1_rd.stp";
    const TopoDS_Shape s = read_step(path);
    Json truth = Json::array();
    std::vector<int> ref_faces;
    for (const double x : {-108.6, -36.2, 36.2, 108.6}) {
      const Box box{x - 24, 50.8 - 24, -248, x + 24, 50.8 + 24, -209};
      const std::vector<int> f = faces_in_box(s, box);
      if (ref_faces.empty()) ref_faces = f;
      truth.push_back(instance(s, f, box, "boss at x " + std::to_string(static_cast<int>(std::lround(x)))));
    }
    save("ftc06_boss_reference", faces_compound(s, ref_faces));
    save("ftc06", s);
    add("ftc06", "real part NIST FTC-06 (144 faces): its 4 bosses with counterbored holes, reference cut from one of them",
        "ftc06_boss_reference", "ftc06", truth, "real");
  }
  // NIST CTC-01: one 25 mm hole (Face82, the wall of the hole at (-160, -45), 50 deep) cut out with a
  // box, as bench/user_cases.py cuts its box references (the hole's box grown by 20 % of its diagonal):
  // a block with the hole, whose sides are cut faces. Only the reference: the target is the part
  // itself (EndToEnd.RoundHolesOfThreeSizesAreEachFoundOnce).
  if (!real_dir.empty()) {
    const std::string path = real_dir + "/nist_ctc_01_asme1_rd.stp";
    const TopoDS_Shape s = read_step(path);
    const double x0 = -172.5, y0 = -57.5, z0 = -50, x1 = -147.5, y1 = -32.5, z1 = 0;
    const double m = 0.2 * std::sqrt((x1 - x0) * (x1 - x0) + (y1 - y0) * (y1 - y0) + (z1 - z0) * (z1 - z0));
    BRepAlgoAPI_Common common(s, BRepPrimAPI_MakeBox(gp_Pnt(x0 - m, y0 - m, z0 - m), gp_Pnt(x1 + m, y1 + m, z1 + m)).Shape());
    if (!common.IsDone()) die("box cut of the CTC-01 hole failed");
    BRepTools::Write(common.Shape(), (dir + "/ctc01_hole_boxcut_reference.brep").c_str());
  }
  std::ofstream(dir + "/suite.json") << Json{{"units", "mm"}, {"cases", cases}}.dump(1) << "\n";
}

// The benchmark plate: 12 ribs scaled 1.0-1.3 and 3 bosses on 210 x 220 mm.
TopoDS_Shape bench_plate(std::size_t* n_ribs) {
  std::vector<Rib> ribs;
  std::vector<Boss> bosses;
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) {
      Rib r{25.0 + 40.0 * i, 40.0 + 70.0 * j};
      r.scale = 1.0 + 0.1 * ((i + j) % 4);
      ribs.push_back(r);
    }
  for (int j = 0; j < 3; ++j) bosses.push_back({185, 40.0 + 70.0 * j});
  *n_ribs = ribs.size();
  return part(210, 220, ribs, bosses);
}

// That plate tessellated to about 10k, 100k, 300k and 1M triangles (read as STL): the scaling benchmark.
void write_scaling(const std::string& root) {
  const std::string dir = root + "/scaling";
  std::filesystem::create_directories(dir);
  std::size_t n_ribs = 0;
  const TopoDS_Shape big = bench_plate(&n_ribs);
  Json sizes = Json::array();
  for (const auto& [name, defl, angle] : std::vector<std::tuple<std::string, double, double>>{
           {"10k", 0.12, 0.35}, {"100k", 0.004, 0.2}, {"300k", 0.0014, 0.2}, {"1m", 0.0004, 0.2}}) {
    BRepTools::Clean(big);
    const fe::TriangleMesh m = tessellate(big, defl, angle);
    fe::write_stl(m, dir + "/plate_" + name + ".stl", true);
    sizes.push_back({{"file", "plate_" + name + ".stl"}, {"triangles", m.triangles.rows()}, {"deflection", defl},
                     {"angular_deflection", angle}});
    std::cout << "fe_make_models: scaling/plate_" << name << ".stl: " << m.triangles.rows() << " triangles\n" << std::flush;
  }
  std::ofstream(dir + "/scaling.json") << Json{{"ribs", n_ribs}, {"sizes", sizes}}.dump(1) << "\n";
}
}  // namespace

int main(int argc, char** argv) {
  const char* usage = "usage: fe_make_models OUTDIR [--bench] [--suite [--real DATA_DIR]] [--scaling]\n";
  if (argc >= 2 && (std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h")) {
    std::cout << usage;
    return 0;
  }
  // an option where the folder belongs (fe_make_models --suite) must not become a folder named "--suite"
  if (argc < 2 || argv[1][0] == '-') {
    std::cerr << usage;
    return 2;
  }
  Message::DefaultMessenger()->RemovePrinters(STANDARD_TYPE(Message_PrinterOStream));
  const std::string dir = argv[1];
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) die(dir + ": cannot create folder: " + ec.message());
  bool bench = false, suite = false, scaling = false;
  std::string real_dir;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--bench") bench = true;
    else if (a == "--real" && i + 1 < argc) real_dir = argv[++i];
    else if (a == "--suite") suite = true;
    else if (a == "--scaling") scaling = true;
    else die("unknown option " + a + " (usage: fe_make_models OUTDIR [--bench] [--suite [--real DATA_DIR]] [--scaling])");
  }
  std::ostringstream truth;
  truth << "{\n";

  // Reference: one rib on a small plate, cut out as its faces.
  {
    Rib r{30, 40};
    const TopoDS_Shape s = part(60, 80, {r}, {});
    const TopoDS_Shape ref = cut_faces(s, 30 - 15, 40 - 30, 30 + 15, 40 + 30);
    write_step(ref, dir + "/rib_reference.step");
    BRepTools::Write(ref, (dir + "/rib_reference.brep").c_str());
  }
  // (a) scaled copies
  {
    std::vector<Rib> ribs;
    const double scales[] = {1.0, 1.2, 1.4, 1.6, 1.8};
    double x = 25;
    truth << "  \"scaled_ribs.step\": [";
    for (int i = 0; i < 5; ++i) {
      Rib r{x, 60};
      r.scale = scales[i];
      ribs.push_back(r);
      truth << (i ? ", " : "") << "{\"center\": " << json_point(x, 60, 0) << ", \"scale\": " << scales[i] << "}";
      x += 30 + 25 * scales[i];
    }
    truth << "],\n";
    write_step(part(x, 120, ribs, {}), dir + "/scaled_ribs.step");
  }
  // (b) five ribs of different top and bottom widths, two bosses
  const std::vector<Rib> ribs_b = [] {
    std::vector<Rib> v;
    const double wb[] = {8, 10, 8, 11, 7}, wt[] = {5, 5, 3, 7, 4.5};
    for (int i = 0; i < 5; ++i) {
      Rib r{25.0 + 35.0 * i, 40};
      r.wb = wb[i];
      r.wt = wt[i];
      v.push_back(r);
    }
    return v;
  }();
  const std::vector<Boss> bosses_b = {{45, 100}, {135, 100, 7.5, 14}};
  const TopoDS_Shape b = part(185, 130, ribs_b, bosses_b);
  write_step(b, dir + "/ribs_bosses.step");
  // a reference cut from the plate itself: the faces of its second rib (10 mm base, 5 mm top)
  BRepTools::Write(cut_faces(b, 60 - 15, 40 - 30, 60 + 15, 40 + 30), (dir + "/rib_wide_reference.brep").c_str());
  truth << "  \"ribs_bosses.step\": {\"ribs\": [";
  for (std::size_t i = 0; i < ribs_b.size(); ++i) truth << (i ? ", " : "") << json_point(ribs_b[i].x, ribs_b[i].y, 0);
  truth << "], \"bosses\": [";
  for (std::size_t i = 0; i < bosses_b.size(); ++i) truth << (i ? ", " : "") << json_point(bosses_b[i].x, bosses_b[i].y, 0);
  truth << "]},\n";
  // (c) cracked, jittered, unwelded STL of (b)
  {
    const fe::TriangleMesh m = tessellate(b, 0.05);
    fe::write_stl(damage(m, 0.03, 0.01, 7), dir + "/ribs_bosses_cracked.stl", true);
  }
  // (d) (b) rotated about an oblique axis through the origin
  {
    gp_Trsf t;
    t.SetRotation(gp_Ax1(gp_Pnt(0, 0, 0), gp_Dir(1, 2, 3)), 0.9);
    write_step(BRepBuilderAPI_Transform(b, t, true).Shape(), dir + "/ribs_bosses_rotated.step");
    const gp_Mat m = t.VectorialPart();
    truth << "  \"ribs_bosses_rotated.step\": {\"rotation\": [";
    for (int i = 1; i <= 3; ++i) truth << (i > 1 ? ", " : "") << json_point(m(i, 1), m(i, 2), m(i, 3));
    truth << "]},\n";
  }
  // References as users make them (issue 9): the first rib cut out of the plate with a box (the
  // paper's way): a closed solid whose 4 side faces and bottom are cut faces found nowhere on the
  // part; also as a closed STL (mesh-only cut detection).
  {
    const TopoDS_Shape cutter = BRepPrimAPI_MakeBox(gp_Pnt(25 - 12, 40 - 26, -10), 24, 52, 30).Shape();
    BRepAlgoAPI_Common common(b, cutter);
    if (!common.IsDone()) die("box cut of the rib failed");
    const TopoDS_Shape boxcut = common.Shape();
    BRepTools::Write(boxcut, (dir + "/rib_boxcut_reference.brep").c_str());
    fe::write_stl(tessellate(boxcut, 0.05), dir + "/rib_boxcut_reference.stl", true);
  }
  // Mirror images (issue 9): L-shaped pads (arms 24 and 14 mm, 6 mm wide, 8 mm high, sharp edges, as
  // machined) and their mirror images on one plate. An L is chiral on a plate: only a reflection maps
  // it onto a mirrored one. Reference: the faces of the first pad.
  {
    auto pad = [](double x, double y, bool mirrored) {
      const double sx = mirrored ? -1 : 1;
      BRepBuilderAPI_MakePolygon poly;
      const double pts[][2] = {{0, 0}, {24, 0}, {24, 6}, {6, 6}, {6, 14}, {0, 14}};
      for (const auto& q : pts) poly.Add(gp_Pnt(x + sx * (q[0] - 12), y + q[1] - 7, -0.5));
      poly.Close();
      return BRepPrimAPI_MakePrism(BRepBuilderAPI_MakeFace(poly.Wire()).Face(), gp_Vec(0, 0, 8.5)).Shape();
    };
    TopoDS_Shape plate = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, -6), 200, 60, 6).Shape();
    const double xs[] = {30, 75, 125, 170};
    truth << "  \"l_pads.step\": [";
    for (int i = 0; i < 4; ++i) {
      const bool mirrored = i >= 2;
      BRepAlgoAPI_Fuse f(plate, pad(xs[i], 30, mirrored));
      if (!f.IsDone()) die("fuse of an L pad failed");
      plate = f.Shape();
      truth << (i ? ", " : "") << "{\"center\": " << json_point(xs[i], 30, 4) << ", \"mirrored\": " << (mirrored ? "true" : "false") << "}";
    }
    truth << "],\n";
    write_step(plate, dir + "/l_pads.step");
    BRepTools::Write(cut_faces(plate, xs[0] - 14, 30 - 9, xs[0] + 14, 30 + 9), (dir + "/l_pad_reference.brep").c_str());
  }
  // Counterbored through holes in one 24 mm plate (issue 9): the reference hole (R4, counterbore R7
  // 5 deep) and one twice its size (R8, counterbore R14 10 deep). The plate keeps its thickness, so
  // the large hole below its counterbore is 14 long where twice the reference's would be 38: its
  // picked cylinder, mapped at 2x, runs on below the plate. Reference: the first hole's three faces.
  {
    TopoDS_Shape plate = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, -24), 150, 70, 24).Shape();
    const double holes[][5] = {{30, 35, 4, 7, 5}, {100, 35, 8, 14, 10}};  // x, y, hole R, counterbore R, depth
    truth << "  \"counterbores.step\": [";
    for (int i = 0; i < 2; ++i) {
      const double* h = holes[i];
      plate = BRepAlgoAPI_Cut(plate, BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(h[0], h[1], -25), gp::DZ()), h[2], 26).Shape()).Shape();
      plate = BRepAlgoAPI_Cut(plate, BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(h[0], h[1], -h[4]), gp::DZ()), h[3], h[4] + 1).Shape()).Shape();
      truth << (i ? ", " : "") << "{\"center\": " << json_point(h[0], h[1], -12) << ", \"scale\": " << h[2] / holes[0][2] << "}";
    }
    truth << "],\n";
    write_step(plate, dir + "/counterbores.step");
    write_first_hole(plate, dir + "/counterbore_reference.brep");
  }
  // A counterbored hole through a taller boss (issue 9; bench/user_cases.py's counterbore_bosses):
  // the reference hole of counterbores.step (R4, counterbore R7 5 deep, through the 24 mm plate) and,
  // at 0.7x, one drilled down through a 20 mm boss and the plate (3x as long for its radius as the
  // reference's: it goes on past the reference's end and leaves the part at the plate's bottom) and
  // one as large but blind (its hole ends on a floor inside the plate: a screw's, not a bolt's).
  // Reference: the first hole's three faces.
  {
    TopoDS_Shape plate = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, -24), 150, 70, 24).Shape();
    for (const double x : {80.0, 125.0}) plate = BRepAlgoAPI_Fuse(plate, BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(x, 35, -1), gp::DZ()), 10, 21).Shape()).Shape();
    const double holes[][6] = {{30, 35, 4, 7, 5, -25}, {80, 35, 2.8, 4.9, 3.5, -25}, {125, 35, 2.8, 4.9, 3.5, -10}};  // x, y, hole R, counterbore R, depth, hole bottom
    for (int i = 0; i < 3; ++i) {
      const double* h = holes[i];
      const double top = i == 0 ? 0 : 20;
      plate = BRepAlgoAPI_Cut(plate, BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(h[0], h[1], h[5]), gp::DZ()), h[2], top + 1 - h[5]).Shape()).Shape();
      plate = BRepAlgoAPI_Cut(plate, BRepPrimAPI_MakeCylinder(gp_Ax2(gp_Pnt(h[0], h[1], top - h[4]), gp::DZ()), h[3], h[4] + 1).Shape()).Shape();
    }
    truth << "  \"counterbore_boss.step\": {\"reference\": " << json_point(30, 35, -12) << ", \"through\": " << json_point(80, 35, 0)
          << ", \"blind\": " << json_point(125, 35, 5) << "},\n";
    write_step(plate, dir + "/counterbore_boss.step");
    write_first_hole(plate, dir + "/counterbore_boss_reference.brep");
  }
  // Triangular blind steps at the corners of a block's top (issue 9; bench/user_cases.py's
  // corner_step_block): a triangular floor and one wall, open toward the block's two sides there,
  // among other floors meeting walls (a rectangular pocket, a through slot). Reference: the first
  // step cut out with the bench's box (its faces' box grown by 10 % of its diagonal), which reaches
  // past the block on three sides: the block's own faces lie on the box there.
  {
    const double W = 100, D = 80, H = 40;
    TopoDS_Shape block = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, 0), W, D, H).Shape();
    const double steps[][5] = {{0, 0, 20, 20, 10}, {100, 0, 30, 15, 8}, {100, 80, 14, 14, 7}, {0, 80, 24, 30, 14}};  // corner x, y, legs, depth
    truth << "  \"corner_step_block.step\": [";
    for (int i = 0; i < 4; ++i) {
      const double* c = steps[i];
      const double sx = c[0] == 0 ? 1 : -1, sy = c[1] == 0 ? 1 : -1, e = 1;
      BRepBuilderAPI_MakePolygon tri(gp_Pnt(c[0] - sx * e, c[1] - sy * e, H - c[4]), gp_Pnt(c[0] + sx * c[2] * (1 + e / c[3]), c[1] - sy * e, H - c[4]),
                                     gp_Pnt(c[0] - sx * e, c[1] + sy * c[3] * (1 + e / c[2]), H - c[4]), true);
      block = BRepAlgoAPI_Cut(block, BRepPrimAPI_MakePrism(BRepBuilderAPI_MakeFace(tri.Wire()).Face(), gp_Vec(0, 0, c[4] + 1)).Shape()).Shape();
      truth << (i ? ", " : "") << json_point(c[0] + sx * c[2] / 3, c[1] + sy * c[3] / 3, H - c[4]);
    }
    truth << "],\n";
    block = BRepAlgoAPI_Cut(block, BRepPrimAPI_MakeBox(gp_Pnt(55, 30, H - 10), 20, 20, 11).Shape()).Shape();  // rectangular pocket
    block = BRepAlgoAPI_Cut(block, BRepPrimAPI_MakeBox(gp_Pnt(40, -1, H - 8), 8, D + 2, 9).Shape()).Shape();  // through slot along y
    write_step(block, dir + "/corner_step_block.step");
    // the first step's floor (z 30, x + y <= 20) and wall: their box, grown by 10 % of its diagonal
    const double x0 = 0, y0 = 0, z0 = 30, x1 = 20, y1 = 20, z1 = 40;
    const double m = 0.1 * std::sqrt((x1 - x0) * (x1 - x0) + (y1 - y0) * (y1 - y0) + (z1 - z0) * (z1 - z0));
    BRepAlgoAPI_Common common(block, BRepPrimAPI_MakeBox(gp_Pnt(x0 - m, y0 - m, z0 - m), gp_Pnt(x1 + m, y1 + m, z1 + m)).Shape());
    if (!common.IsDone()) die("box cut of the corner step failed");
    BRepTools::Write(common.Shape(), (dir + "/corner_step_boxcut_reference.brep").c_str());
  }
  // bad-input helpers: a flat reference and a target with nothing similar
  write_step(BRepBuilderAPI_MakeFace(gp_Pln(gp::Origin(), gp::DZ()), 0, 30, 0, 20).Shape(), dir + "/flat_reference.step");
  write_step(part(120, 80, {}, {{30, 40}, {90, 40, 8, 10}}), dir + "/boss_only.step");
  if (bench) {
    std::size_t n_ribs = 0;
    const TopoDS_Shape big = bench_plate(&n_ribs);
    const fe::TriangleMesh m = tessellate(big, 0.004);
    fe::write_stl(m, dir + "/bench_100k.stl", true);
    truth << "  \"bench_100k.stl\": {\"ribs\": " << n_ribs << ", \"triangles\": " << m.triangles.rows() << "},\n";
  }
  if (suite) write_suite(dir, b, ribs_b, real_dir);
  if (scaling) write_scaling(dir);
  truth << "  \"units\": \"mm\"\n}\n";
  std::ofstream(dir + "/truth.json") << truth.str();
  std::cout << "fe_make_models: wrote models to " << dir << "\n";
  return 0;
}
