// B-rep input: STEP, IGES and BREP read with OpenCASCADE and tessellated with BRepMesh.
// Faces are numbered 1..n in TopExp::MapShapes(shape, TopAbs_FACE) order, which is FreeCAD's FaceN.
#include "featureextract/io.h"

#include "isolate.h"

#include <BRepBndLib.hxx>
#include <BRepMesh_IncrementalMesh.hxx>
#include <BRepTools.hxx>
#include <BRep_Builder.hxx>
#include <BRep_Tool.hxx>
#include <Bnd_Box.hxx>
#include <IGESControl_Reader.hxx>
#include <Message.hxx>
#include <Message_Messenger.hxx>
#include <Message_PrinterOStream.hxx>
#include <Poly_Triangulation.hxx>
#include <STEPControl_Reader.hxx>
#include <Standard_Failure.hxx>
#include <TopExp.hxx>
#include <TopLoc_Location.hxx>
#include <TopTools_IndexedMapOfShape.hxx>
#include <TopoDS.hxx>
#include <TopoDS_Face.hxx>
#include <TopoDS_Shape.hxx>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <sstream>

namespace fe {

namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what) { throw InputError(path + ": " + what); }

void silence_occt() {
  static std::once_flag once;
  std::call_once(once, [] {
    const Handle(Message_Messenger)& m = Message::DefaultMessenger();
    m->RemovePrinters(STANDARD_TYPE(Message_PrinterOStream));
  });
}

TopoDS_Shape read_occt(const std::string& path, const std::string& ext) {
  TopoDS_Shape shape;
  if (ext == "step" || ext == "stp") {
    STEPControl_Reader r;
    if (r.ReadFile(path.c_str()) != IFSelect_RetDone) fail(path, "not a readable STEP file");
    if (r.TransferRoots() == 0) fail(path, "STEP file holds no transferable shape");
    shape = r.OneShape();
  } else if (ext == "iges" || ext == "igs") {
    IGESControl_Reader r;
    if (r.ReadFile(path.c_str()) != IFSelect_RetDone) fail(path, "not a readable IGES file");
    if (r.TransferRoots() == 0) fail(path, "IGES file holds no transferable shape");
    shape = r.OneShape();
  } else {
    BRep_Builder b;
    if (!BRepTools::Read(shape, path.c_str(), b)) fail(path, "not a readable BREP file");
  }
  if (shape.IsNull()) fail(path, "file holds no shape");
  return shape;
}

TriangleMesh tessellate(const TopoDS_Shape& shape, const TessellationOptions& o, const std::string& name) {
  TopTools_IndexedMapOfShape faces;
  TopExp::MapShapes(shape, TopAbs_FACE, faces);
  if (faces.Extent() == 0) fail(name, "shape has no faces (wires or points only)");
  Bnd_Box box;
  BRepBndLib::Add(shape, box);
  if (box.IsVoid()) fail(name, "shape has an empty bounding box");
  double x0, y0, z0, x1, y1, z1;
  box.Get(x0, y0, z0, x1, y1, z1);
  const double diag = std::sqrt((x1 - x0) * (x1 - x0) + (y1 - y0) * (y1 - y0) + (z1 - z0) * (z1 - z0));
  if (!(diag > 0) || !std::isfinite(diag)) fail(name, "shape has zero or infinite size");
  if (!(std::isfinite(o.relative_deflection) && o.relative_deflection > 0) || !std::isfinite(o.absolute_deflection) ||
      o.absolute_deflection < 0 || !(std::isfinite(o.angular_deflection) && o.angular_deflection > 0))
    fail(name, "tessellation deflections must be finite and positive (relative " + std::to_string(o.relative_deflection) +
                   ", absolute " + std::to_string(o.absolute_deflection) + ", angular " +
                   std::to_string(o.angular_deflection) + ")");
  double defl = o.relative_deflection * diag;
  // a deflection far below the shape size would make BRepMesh run for hours: bound the triangle count
  defl = std::max(defl, 1e-5 * diag);
  if (o.absolute_deflection > 0) defl = std::min(defl, o.absolute_deflection);
  // not in parallel: this runs in a forked child, where a thread pool inherited from the parent
  // (FreeCAD's own meshing) has no threads behind it
  BRepMesh_IncrementalMesh mesher(shape, defl, Standard_False, o.angular_deflection, Standard_False);
  if (!mesher.IsDone()) fail(name, "OpenCASCADE could not tessellate the shape");

  std::vector<double> v;
  std::vector<int> t, f;
  int missing = 0;
  for (int i = 1; i <= faces.Extent(); ++i) {
    const TopoDS_Face& face = TopoDS::Face(faces(i));
    TopLoc_Location loc;
    Handle(Poly_Triangulation) tri = BRep_Tool::Triangulation(face, loc);
    if (tri.IsNull()) { ++missing; continue; }
    const gp_Trsf tr = loc.Transformation();
    const int base = static_cast<int>(v.size() / 3);
    for (int k = 1; k <= tri->NbNodes(); ++k) {
      const gp_Pnt p = tri->Node(k).Transformed(tr);
      v.push_back(p.X());
      v.push_back(p.Y());
      v.push_back(p.Z());
    }
    const bool reversed = face.Orientation() == TopAbs_REVERSED;
    for (int k = 1; k <= tri->NbTriangles(); ++k) {
      int a, b, c;
      tri->Triangle(k).Get(a, b, c);
      if (reversed) std::swap(b, c);
      t.push_back(base + a - 1);
      t.push_back(base + b - 1);
      t.push_back(base + c - 1);
      f.push_back(i);
    }
  }
  if (t.empty()) fail(name, "tessellation produced no triangles");
  TriangleMesh m;
  m.source = name;
  m.num_faces = faces.Extent();
  m.vertices = Eigen::Map<Points>(v.data(), static_cast<Eigen::Index>(v.size() / 3), 3);
  m.triangles = Eigen::Map<Triangles>(t.data(), static_cast<Eigen::Index>(t.size() / 3), 3);
  m.face_ids = Eigen::Map<Eigen::VectorXi>(f.data(), static_cast<Eigen::Index>(f.size()));
  (void)missing;  // faces OCCT could not mesh simply get no samples
  return m;
}

// The child's time limit in seconds (0 = none) for an input of `bytes`.
double time_limit(const std::string& name, const TessellationOptions& o, double bytes) {
  if (!std::isfinite(o.time_limit)) fail(name, "the reading time limit must be finite");
  return o.time_limit < 0 ? 20.0 + 10.0 * bytes / 1e6 : o.time_limit;
}

}  // namespace

namespace {

// Runs `tessellated()` in the reader child (isolate.h), with OpenCASCADE's exceptions turned into
// InputError naming `name`.
template <class F>
TriangleMesh read_guarded(const std::string& name, double limit, bool callers_limit, F tessellated) {
  return read_isolated(name, [&] {
    silence_occt();
    try {
      return tessellated();
    } catch (const InputError&) {
      throw;
    } catch (const Standard_Failure& e) {
      fail(name, std::string("OpenCASCADE failed: ") + (e.GetMessageString() ? e.GetMessageString() : "unknown error"));
    } catch (const std::exception& e) {
      fail(name, e.what());
    }
  }, limit, callers_limit);
}

}  // namespace

TriangleMesh read_brep_file(const std::string& path, const std::string& ext, const TessellationOptions& o) {
  std::error_code ec;
  const double limit = time_limit(path, o, static_cast<double>(std::filesystem::file_size(path, ec)));
  return read_guarded(path, limit, o.time_limit > 0, [&] { return tessellate(read_occt(path, ext), o, path); });
}

TriangleMesh read_brep_string(const std::string& brep, const TessellationOptions& o, const std::string& name) {
  const double limit = time_limit(name, o, static_cast<double>(brep.size()));
  TriangleMesh m = read_guarded(name, limit, o.time_limit > 0, [&] {
    std::istringstream in(brep);
    TopoDS_Shape shape;
    BRep_Builder b;
    BRepTools::Read(shape, in, b);
    if (shape.IsNull()) fail(name, "not a readable BREP string");
    return tessellate(shape, o, name);
  });
  validate_mesh(m);
  return m;
}

}  // namespace fe
