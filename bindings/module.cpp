// pybind11 mirror of the C++ API (core/include/featureextract). Only type translation lives in the
// bindings: numpy <-> Eigen, C++ exceptions <-> Python exceptions, the progress callback <-> Python
// callable. One file per public header (bind_*.cpp); this one makes the module and its exceptions.
#include "common.h"
#include "featureextract/extract.h"

PYBIND11_MODULE(_core, m) {
  m.doc() = "FeatureExtract core: find regions of a target shape similar to a reference feature "
            "(Takashima & Kanai). See the featureextract package for the documented API.";

  static py::exception<fe::InputError> input_error(m, "InputError", PyExc_ValueError);
  static py::exception<fe::Cancelled> cancelled(m, "Cancelled", PyExc_RuntimeError);
  static py::exception<fe::TimeLimitExceeded> time_limit(m, "TimeLimitError", PyExc_TimeoutError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const fe::InputError& e) {
      input_error(e.what());
    } catch (const fe::Cancelled& e) {
      cancelled(e.what());
    } catch (const fe::TimeLimitExceeded& e) {
      time_limit(e.what());
    }
  });

  // in this order: a binding's default arguments and signatures use the types bound before it
  fe_py::bind_mesh(m);
  fe_py::bind_io(m);
  fe_py::bind_params(m);
  fe_py::bind_result(m);
  fe_py::bind_extract(m);
  fe_py::bind_femesh(m);
  fe_py::bind_transfer(m);
}
