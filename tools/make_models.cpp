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
// Units are millimetres. Everything is deterministic.
#include "featureextract/io.h"

#include <BRepAlgoAPI_Fuse.hxx>
#include <BRepBuilderAPI_MakePolygon.hxx>
#include <BRepBuilderAPI_MakeFace.hxx>
#include <BRepBuilderAPI_Transform.hxx>
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
#include <vector>

namespace {

struct Rib {
  double x, y;        // footprint center on the plate top (z = 0)
  double length = 40; // along y
  double wb = 8, wt = 5, h = 12;
  double scale = 1;   // isotropic scale of the whole rib (fillets too)
  double r_top = 1.2, r_root = 1.5;
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

[[noreturn]] void die(const std::string& m) {
  std::cerr << "fe_make_models: " << m << "\n";
  std::exit(1);
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
  gp_Trsf t;
  t.SetTranslation(gp_Vec(r.x, r.y, 0));
  return BRepBuilderAPI_Transform(fil.Shape(), t, true).Shape();
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
TopoDS_Shape part(double sx, double sy, const std::vector<Rib>& ribs, const std::vector<Boss>& bosses) {
  TopoDS_Shape s = BRepPrimAPI_MakeBox(gp_Pnt(0, 0, -6), gp_Pnt(sx, sy, 0)).Shape();
  for (const Rib& r : ribs) s = BRepAlgoAPI_Fuse(s, rib_solid(r)).Shape();
  for (const Boss& b : bosses) s = BRepAlgoAPI_Fuse(s, boss_solid(b)).Shape();
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
      if (std::abs(0.5 * (x0 + x1) - r.x) < r.wb * r.scale && std::abs(0.5 * (y0 + y1) - r.y) < r.length * r.scale) rr = r.r_root * r.scale;
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

fe::TriangleMesh tessellate(const TopoDS_Shape& s, double defl) {
  BRepMesh_IncrementalMesh(s, defl, false, 0.2, true);
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

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::cerr << "usage: fe_make_models OUTDIR [--bench]\n";
    return 2;
  }
  Message::DefaultMessenger()->RemovePrinters(STANDARD_TYPE(Message_PrinterOStream));
  const std::string dir = argv[1];
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  if (ec) die(dir + ": cannot create folder: " + ec.message());
  const bool bench = argc > 2 && std::string(argv[2]) == "--bench";
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
  // bad-input helpers: a flat reference and a target with nothing similar
  write_step(BRepBuilderAPI_MakeFace(gp_Pln(gp::Origin(), gp::DZ()), 0, 30, 0, 20).Shape(), dir + "/flat_reference.step");
  write_step(part(120, 80, {}, {{30, 40}, {90, 40, 8, 10}}), dir + "/boss_only.step");
  if (bench) {
    std::vector<Rib> ribs;
    std::vector<Boss> bosses;
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 3; ++j) {
        Rib r{25.0 + 40.0 * i, 40.0 + 70.0 * j};
        r.scale = 1.0 + 0.1 * ((i + j) % 4);
        ribs.push_back(r);
      }
    for (int j = 0; j < 3; ++j) bosses.push_back({185, 40.0 + 70.0 * j});
    const TopoDS_Shape big = part(210, 220, ribs, bosses);
    const fe::TriangleMesh m = tessellate(big, 0.004);
    fe::write_stl(m, dir + "/bench_100k.stl", true);
    truth << "  \"bench_100k.stl\": {\"ribs\": " << ribs.size() << ", \"triangles\": " << m.triangles.rows() << "},\n";
  }
  truth << "  \"units\": \"mm\"\n}\n";
  std::ofstream(dir + "/truth.json") << truth.str();
  std::cout << "fe_make_models: wrote models to " << dir << "\n";
  return 0;
}
