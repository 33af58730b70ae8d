// Shared by the binding files (one per public header of the core, bind_*.cpp; the module itself in
// module.cpp): the progress callback <-> Python callable, and the functions that bind each header.
#pragma once

#include "featureextract/extract.h"
#include "featureextract/femesh.h"
#include "featureextract/mesh.h"

#include <pybind11/pybind11.h>

#include <memory>
#include <string>
#include <vector>

namespace py = pybind11;

namespace fe_py {

// Wraps a Python progress callable for use from the (GIL-released) core: the GIL is taken only for
// the call. The callable returns False to cancel; None or True to go on. A Python exception inside
// it cancels too, and is re-raised after the core has stopped.
struct PyProgress {
  py::object fn;
  std::shared_ptr<py::error_already_set> error;
  bool operator()(const std::string& stage, double fraction) {
    py::gil_scoped_acquire gil;
    try {
      py::object r = fn(stage, fraction);
      return r.is_none() || r.cast<bool>();
    } catch (py::error_already_set& e) {
      error = std::make_shared<py::error_already_set>(std::move(e));
      return false;
    }
  }
};

inline fe::ProgressFn make_progress(const py::object& fn, PyProgress*& holder, std::shared_ptr<PyProgress>& keep) {
  if (fn.is_none()) return {};
  keep = std::make_shared<PyProgress>(PyProgress{fn, nullptr});
  holder = keep.get();
  return [keep](const std::string& s, double f) { return (*keep)(s, f); };
}

// Runs body(progress_fn) with the GIL released; a cancellation caused by an exception inside the
// Python callback re-raises that exception.
template <typename F>
auto run_released(const py::object& progress, F&& body) -> decltype(body(fe::ProgressFn{})) {
  PyProgress* holder = nullptr;
  std::shared_ptr<PyProgress> keep;
  const fe::ProgressFn pf = make_progress(progress, holder, keep);
  try {
    py::gil_scoped_release release;
    return body(pf);
  } catch (const fe::Cancelled&) {
    if (holder && holder->error) throw *holder->error;
    throw;
  }
}

/// Element quality as numpy arrays (aspect_ratio, scaled_jacobian, min_angle_deg, inverted), and a
/// quality summary as a dict (bind_femesh.cpp).
py::dict quality_arrays(const std::vector<fe::ElementQuality>& q);
py::dict summary_dict(const fe::QualitySummary& q);

void bind_mesh(py::module_& m);      // mesh.h
void bind_io(py::module_& m);        // io.h
void bind_params(py::module_& m);    // params.h
void bind_result(py::module_& m);    // result.h
void bind_extract(py::module_& m);   // extract.h
void bind_femesh(py::module_& m);    // femesh.h
void bind_transfer(py::module_& m);  // transfer.h

}  // namespace fe_py
