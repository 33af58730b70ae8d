// Bindings of featureextract/io.h.
#include "common.h"
#include "featureextract/io.h"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <cmath>

namespace fe_py {

void bind_io(py::module_& m) {
  m.def("read_shape", [](const std::string& path, double relative_deflection, double absolute_deflection, double time_limit) {
        fe::TessellationOptions o;
        o.relative_deflection = relative_deflection;
        o.absolute_deflection = absolute_deflection;
        o.time_limit = time_limit;
        py::gil_scoped_release release;
        return fe::read_shape(path, o);
      },
      py::arg("path"), py::arg("relative_deflection") = fe::TessellationOptions{}.relative_deflection,
      py::arg("absolute_deflection") = 0.0, py::arg("time_limit") = fe::TessellationOptions{}.time_limit,
      "Read STEP/IGES/BREP (tessellated, in a child process stopped after time_limit seconds; < 0: 20 s + 10 s "
      "per MB) or STL/OBJ/PLY. Raises InputError naming the file, also when the CAD reader crashes or hangs.");
  m.def("read_brep_string", [](const std::string& brep, const std::string& name, double relative_deflection, double absolute_deflection,
                               double time_limit) {
        fe::TessellationOptions o;
        o.relative_deflection = relative_deflection;
        o.absolute_deflection = absolute_deflection;
        o.time_limit = time_limit;
        py::gil_scoped_release release;
        return fe::read_brep_string(brep, o, name);
      },
      py::arg("brep"), py::arg("name") = "<brep string>", py::arg("relative_deflection") = fe::TessellationOptions{}.relative_deflection,
      py::arg("absolute_deflection") = 0.0, py::arg("time_limit") = fe::TessellationOptions{}.time_limit,
      "Tessellate a B-rep from Part.Shape.exportBrepToString() (in a child process, like read_shape); faces keep "
      "FreeCAD's FaceN numbering.");

  m.def("size_on_ladder", &fe::size_on_ladder, py::arg("L"), py::arg("steps"),
        "The feature size the search uses: L itself with steps 0, else the nearest 2^(k / steps) (Params.size_ladder).");
  m.def("tessellation_for_feature", [](double L) {
    const auto o = fe::tessellation_for_feature(L);
    return py::make_tuple(o.relative_deflection, o.absolute_deflection);
  }, "(relative, absolute) deflection to read a target searched for a feature of diagonal L");
}

}  // namespace fe_py
