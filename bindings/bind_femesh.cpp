// Bindings of featureextract/femesh.h.
#include "common.h"
#include "featureextract/femesh.h"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <cmath>

namespace fe_py {

py::dict quality_arrays(const std::vector<fe::ElementQuality>& q) {
  Eigen::VectorXd ar(static_cast<Eigen::Index>(q.size())), sj(ar.size()), ang(ar.size());
  Eigen::Matrix<bool, Eigen::Dynamic, 1> inv(ar.size());
  for (std::size_t i = 0; i < q.size(); ++i) {
    const auto k = static_cast<Eigen::Index>(i);
    ar(k) = q[i].aspect_ratio;
    sj(k) = q[i].scaled_jacobian;
    ang(k) = q[i].min_angle_deg;
    inv(k) = q[i].inverted;
  }
  py::dict d;
  d["aspect_ratio"] = ar;
  d["scaled_jacobian"] = sj;
  d["min_angle_deg"] = ang;
  d["inverted"] = inv;
  return d;
}

py::dict summary_dict(const fe::QualitySummary& q) {
  py::dict d;
  d["elements"] = q.elements;
  d["inverted"] = q.inverted;
  d["min_scaled_jacobian"] = q.min_scaled_jacobian;
  d["median_scaled_jacobian"] = q.median_scaled_jacobian;
  d["max_aspect_ratio"] = q.max_aspect_ratio;
  d["median_aspect_ratio"] = q.median_aspect_ratio;
  d["min_angle_deg"] = q.min_angle_deg;
  return d;
}

void bind_femesh(py::module_& m) {
  py::class_<fe::FeMesh>(m, "FeMesh", "A finite-element mesh (S3/S4 shells, C3D4/C3D8/C3D10 solids) with named node and element sets.")
      .def_readonly("nodes", &fe::FeMesh::nodes, "(N, 3) node coordinates")
      .def_readonly("node_ids", &fe::FeMesh::node_ids, "external node ids")
      .def_readonly("node_sets", &fe::FeMesh::node_sets, "name -> 0-based node indices")
      .def_readonly("element_sets", &fe::FeMesh::element_sets, "name -> 0-based element indices (blocks in order)")
      .def_property_readonly("num_elements", &fe::FeMesh::num_elements)
      .def_property_readonly("blocks", [](const fe::FeMesh& x) {
        py::list out;
        for (const auto& b : x.blocks) out.append(py::make_tuple(fe::inp_type_name(b.type), b.ids, b.conn, b.elset));
        return out;
      }, "[(type 'S3'|'S4'|'C3D4'|'C3D8'|'C3D10', external ids, (n, k) 0-based node indices, elset name)]");
  m.def("read_fe_mesh", &fe::read_fe_mesh, py::arg("path"), "Reads a .inp or .msh mesh (raises InputError naming the file).");
  m.def("write_inp", &fe::write_inp, py::arg("mesh"), py::arg("path"));
  m.def("write_msh", &fe::write_msh, py::arg("mesh"), py::arg("path"), "gmsh ASCII 4.1");
  m.def("element_quality", [](const fe::FeMesh& x) { return quality_arrays(fe::element_quality(x)); }, py::arg("mesh"),
        "Per element: aspect_ratio, scaled_jacobian, min_angle_deg, inverted (numpy arrays).");
}

}  // namespace fe_py
