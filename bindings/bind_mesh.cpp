// Bindings of featureextract/mesh.h.
#include "common.h"
#include "featureextract/io.h"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include <optional>

namespace fe_py {

namespace {

fe::TriangleMesh mesh_from_arrays(const fe::Points& v, const fe::Triangles& t, const std::optional<Eigen::VectorXi>& faces,
                                  const std::string& name) {
  fe::TriangleMesh m;
  m.vertices = v;
  m.triangles = t;
  m.source = name;
  if (faces) {
    if (faces->size() != t.rows()) throw fe::InputError(name + ": face_ids has " + std::to_string(faces->size()) + " entries for " + std::to_string(t.rows()) + " triangles");
    m.face_ids = *faces;  // range-checked by validate_mesh
  }
  fe::validate_mesh(m);
  return m;
}

}  // namespace

void bind_mesh(py::module_& m) {
  py::class_<fe::TriangleMesh>(m, "Mesh", "A triangle soup with per-triangle B-rep face ids (1-based FaceN, 0 for mesh input).")
      .def(py::init(&mesh_from_arrays), py::arg("vertices"), py::arg("triangles"), py::arg("face_ids") = py::none(),
           py::arg("name") = "<arrays>",
           "Mesh from numpy arrays: vertices (N, 3) float, triangles (T, 3) int (0-based), optional face_ids (T,) "
           "1-based FaceN per triangle. Validated like a file (raises InputError).")
      .def_readonly("vertices", &fe::TriangleMesh::vertices)
      .def_readonly("triangles", &fe::TriangleMesh::triangles)
      .def_readonly("face_ids", &fe::TriangleMesh::face_ids)
      .def_readonly("num_faces", &fe::TriangleMesh::num_faces)
      .def_readonly("source", &fe::TriangleMesh::source)
      .def_readonly("dropped_degenerate", &fe::TriangleMesh::dropped_degenerate)
      .def_readonly("reoriented", &fe::TriangleMesh::reoriented)
      .def_property_readonly("diagonal", &fe::TriangleMesh::diagonal, "bounding-box diagonal")
      .def("__repr__", [](const fe::TriangleMesh& x) {
        return "<featureextract.Mesh " + x.source + ": " + std::to_string(x.triangles.rows()) + " triangles, " +
               std::to_string(x.num_faces) + " faces>";
      });
}

}  // namespace fe_py
