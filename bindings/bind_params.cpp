// Bindings of featureextract/params.h: one property per documented parameter.
#include "common.h"
#include "featureextract/params.h"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <cmath>

namespace fe_py {

void bind_params(py::module_& m) {
  auto params = py::class_<fe::Params>(m, "Params", "Extraction parameters; lengths are fractions of L, the reference diagonal.");
  params.def(py::init<>())
      .def("validate", &fe::Params::validate)
      .def("to_json", [](const fe::Params& p) { return fe::params_to_json(p); })
      .def_static("from_json", [](const std::string& s) {
        try {
          return fe::params_from_json(s);
        } catch (const std::invalid_argument& e) {
          throw fe::InputError(e.what());
        }
      });
  // One property per documented parameter, with its help, unit and default as the docstring.
  for (const fe::ParamInfo& info : fe::param_table()) {
    const std::string name = info.name;
    const std::string doc = info.help + (info.unit.empty() ? "" : " [" + info.unit + "]") + " (default " + info.default_value + ")";
    params.def_property(
        name.c_str(),
        [name](const fe::Params& p) -> py::object {
          const py::dict d = py::module_::import("json").attr("loads")(fe::params_to_json(p));
          return d[py::str(name)];
        },
        [name](fe::Params& p, py::object v) {
          // bad values are bad input: fx.InputError (a ValueError) naming the parameter
          if (py::isinstance<py::float_>(v) && !std::isfinite(v.cast<double>()))
            throw fe::InputError("parameter " + name + " must be a finite number");
          std::string j;
          try {
            j = py::module_::import("json").attr("dumps")(py::dict(py::arg(name.c_str()) = v)).cast<std::string>();
          } catch (const py::error_already_set&) {
            throw fe::InputError("parameter " + name + " must be a number or true/false, not " + std::string(py::str(v.get_type().attr("__name__"))));
          }
          try {
            p = fe::params_from_json(j, p);
          } catch (const std::invalid_argument& e) {
            throw fe::InputError(e.what());
          }
        },
        doc.c_str());
  }
  m.def("param_table", [] {
    py::list out;
    for (const auto& i : fe::param_table())
      out.append(py::dict(py::arg("name") = i.name, py::arg("type") = i.type, py::arg("unit") = i.unit, py::arg("help") = i.help,
                          py::arg("default") = i.default_value, py::arg("group") = i.group));
    return out;
  }, "Every parameter, step by step: name, type, unit, help, default, group (the paper's step).");
}

}  // namespace fe_py
