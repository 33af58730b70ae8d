// Bindings of featureextract/transfer.h: feature folders and the mesh transfer.
#include "common.h"
#include "featureextract/transfer.h"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <cmath>

namespace fe_py {

void bind_transfer(py::module_& m) {
  py::class_<fe::FeatureModel>(m, "FeatureModel", "A reference feature folder: feature.json, geometry, FE mesh.")
      .def_readonly("dir", &fe::FeatureModel::dir)
      .def_readonly("name", &fe::FeatureModel::name)
      .def_readonly("geometry_path", &fe::FeatureModel::geometry_path)
      .def_readonly("mesh_path", &fe::FeatureModel::mesh_path)
      .def_readonly("mesh", &fe::FeatureModel::mesh)
      .def_readonly("spec_json", &fe::FeatureModel::spec_json);
  m.def("read_feature", &fe::read_feature, py::arg("dir"), "Reads a reference feature folder (raises InputError naming the file).");
  py::class_<fe::TransferredMesh>(m, "TransferredMesh", "A reference mesh placed on one found instance.")
      .def_readonly("mesh", &fe::TransferredMesh::mesh)
      .def_property_readonly("quality_before", [](const fe::TransferredMesh& t) { return quality_arrays(t.before); })
      .def_property_readonly("quality_after", [](const fe::TransferredMesh& t) { return quality_arrays(t.after); })
      .def_property_readonly("summary_before", [](const fe::TransferredMesh& t) { return summary_dict(t.before_summary); })
      .def_property_readonly("summary_after", [](const fe::TransferredMesh& t) { return summary_dict(t.after_summary); })
      .def_readonly("projected", &fe::TransferredMesh::projected)
      .def_readonly("unprojected", &fe::TransferredMesh::unprojected)
      .def_readonly("max_projection_distance", &fe::TransferredMesh::max_projection_distance)
      .def_readonly("max_surface_distance", &fe::TransferredMesh::max_surface_distance)
      .def_readonly("invalid_elements", &fe::TransferredMesh::invalid_elements)
      .def_readonly("reversed", &fe::TransferredMesh::reversed, "element order reversed for a mirrored instance")
      .def_readonly("spec_json", &fe::TransferredMesh::spec_json);
  m.def("transfer_mesh", [](const fe::FeMesh& mesh, const Eigen::Matrix4d& H, const fe::TriangleMesh& target, double max_projection,
                            const std::string& spec_json) {
        fe::TransferOptions o;
        o.max_projection = max_projection;
        py::gil_scoped_release release;
        return fe::transfer_mesh(mesh, H, target, o, spec_json);
      },
      py::arg("mesh"), py::arg("transform"), py::arg("target"), py::arg("max_projection") = fe::TransferOptions{}.max_projection,
      py::arg("spec_json") = "{}",
      "Maps the mesh's nodes by the 4x4 transform, moves them onto the target surface, measures quality before and after.");
}

}  // namespace fe_py
