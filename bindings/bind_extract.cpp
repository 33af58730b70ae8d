// Bindings of featureextract/extract.h: the search, a prepared target, descriptions.
#include "common.h"
#include "featureextract/extract.h"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <cmath>

namespace fe_py {

void bind_extract(py::module_& m) {
  m.def("extract", [](const fe::TriangleMesh& ref, const fe::TriangleMesh& tgt, const fe::Params& p, const py::object& progress) {
        return run_released(progress, [&](const fe::ProgressFn& pf) { return fe::extract(ref, tgt, p, pf); });
      },
      py::arg("reference"), py::arg("target"), py::arg("params") = fe::Params{}, py::arg("progress") = py::none(),
      "All six steps; releases the GIL. progress(stage, fraction) may return False to cancel (raises Cancelled).");

  py::class_<fe::PreparedTarget>(m, "PreparedTarget", "A target whose descriptors are computed once and reused across references.")
      .def(py::init<fe::TriangleMesh>(), py::arg("mesh"))
      .def_property_readonly("mesh", &fe::PreparedTarget::mesh)
      .def_property_readonly("descriptions_built", &fe::PreparedTarget::descriptions_built)
      .def("extract", [](fe::PreparedTarget& t, const fe::TriangleMesh& ref, const fe::Params& p, const py::object& progress) {
            return run_released(progress, [&](const fe::ProgressFn& pf) { return t.extract(ref, p, pf); });
          },
          py::arg("reference"), py::arg("params") = fe::Params{}, py::arg("progress") = py::none());

  py::class_<fe::ShapeDescription> desc(m, "Description", "Steps 1-3 of one shape: samples, key points, descriptors.");
  py::enum_<fe::ShapeDescription::Role>(desc, "Role")
      .value("Reference", fe::ShapeDescription::Role::Reference)
      .value("Target", fe::ShapeDescription::Role::Target);
  desc.def_property_readonly("dense_points", &fe::ShapeDescription::dense_points)
      .def_property_readonly("sparse_points", &fe::ShapeDescription::sparse_points)
      .def_property_readonly("key_points", &fe::ShapeDescription::key_points)
      .def_property_readonly("key_shape_index", &fe::ShapeDescription::key_shape_index)
      .def_property_readonly("stats", &fe::ShapeDescription::stats)
      .def_property_readonly("feature_size", &fe::ShapeDescription::feature_size)
      .def_property_readonly("warnings", &fe::ShapeDescription::warnings);
  m.def("describe", [](const fe::TriangleMesh& mesh, fe::ShapeDescription::Role role, double feature_size, const fe::Params& p,
                       const py::object& progress) {
        return run_released(progress, [&](const fe::ProgressFn& pf) { return fe::describe(mesh, role, feature_size, p, pf); });
      },
      py::arg("mesh"), py::arg("role"), py::arg("feature_size"), py::arg("params") = fe::Params{}, py::arg("progress") = py::none(),
      "Steps 1-3 for one shape (feature_size = L, the reference diagonal); for display and inspection.");
}

}  // namespace fe_py
