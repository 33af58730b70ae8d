// pybind11 mirror of the C++ API (core/include/featureextract). Only type translation lives here:
// numpy <-> Eigen, C++ exceptions <-> Python exceptions, the progress callback <-> Python callable.
#include "featureextract/extract.h"
#include "featureextract/io.h"
#include "featureextract/transfer.h"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <cmath>

namespace py = pybind11;

namespace {

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

fe::ProgressFn make_progress(const py::object& fn, PyProgress*& holder, std::shared_ptr<PyProgress>& keep) {
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
                          py::arg("default") = i.default_value));
    return out;
  }, "Every parameter: name, type, unit, help, default.");

  py::class_<fe::Match>(m, "Match", "One found instance.")
      .def_readonly("transform", &fe::Match::transform, "4x4 H mapping reference to target coordinates (h44 = 1)")
      .def_readonly("score", &fe::Match::score)
      .def_readonly("max_error", &fe::Match::max_error)
      .def_readonly("rms_error", &fe::Match::rms_error)
      .def_readonly("rms_error_unrefined", &fe::Match::rms_error_unrefined, "RMS fit error before the surface refinement")
      .def_readonly("scale", &fe::Match::scale)
      .def_readonly("center", &fe::Match::center)
      .def_readonly("bbox_min", &fe::Match::bbox_min)
      .def_readonly("bbox_max", &fe::Match::bbox_max)
      .def_readonly("faces", &fe::Match::faces, "1-based target FaceN covered (B-rep input)")
      .def_readonly("triangles", &fe::Match::triangles, "0-based target triangles covered (mesh input)")
      .def_readonly("pairs", &fe::Match::pairs)
      .def_readonly("key_agreement", &fe::Match::key_agreement, "fraction of reference key points landing near target key points of similar shape index")
      .def_readonly("stretch_min", &fe::Match::stretch_min, "smallest singular value of H's Jacobian at the feature's center")
      .def_readonly("stretch_max", &fe::Match::stretch_max, "largest singular value of H's Jacobian at the feature's center")
      .def_readonly("perspective", &fe::Match::perspective, "largest |w - 1| of H over the reference feature's box")
      .def_readonly("obstructed", &fe::Match::obstructed, "fraction of the reference's free-space rays (along its outward normals) that meet target surface")
      .def_readonly("mirrored", &fe::Match::mirrored, "found as the reference's mirror image (negative determinant)");

  py::class_<fe::ShapeStats>(m, "ShapeStats")
      .def_readonly("triangles", &fe::ShapeStats::triangles)
      .def_readonly("faces", &fe::ShapeStats::faces)
      .def_readonly("dense_points", &fe::ShapeStats::dense_points)
      .def_readonly("sparse_points", &fe::ShapeStats::sparse_points)
      .def_readonly("key_points", &fe::ShapeStats::key_points)
      .def_readonly("descriptors", &fe::ShapeStats::descriptors)
      .def_readonly("diagonal", &fe::ShapeStats::diagonal);

  py::class_<fe::Result>(m, "Result")
      .def_readonly("matches", &fe::Result::matches)
      .def_readonly("reference", &fe::Result::reference)
      .def_readonly("target", &fe::Result::target)
      .def_readonly("feature_size", &fe::Result::feature_size)
      .def_readonly("timings", &fe::Result::timings)
      .def_readonly("warnings", &fe::Result::warnings)
      .def_readonly("params", &fe::Result::params)
      .def_readonly("symmetry", &fe::Result::symmetry, "'none' or 'axisymmetric' (the reference's)")
      .def_readonly("symmetry_point", &fe::Result::symmetry_point)
      .def_readonly("symmetry_axis", &fe::Result::symmetry_axis)
      .def_readonly("mirror_searched", &fe::Result::mirror_searched, "the reference's mirror image was searched too")
      .def_readonly("reference_mirror_symmetric", &fe::Result::reference_mirror_symmetric)
      .def_readonly("reference_closed", &fe::Result::reference_closed, "the reference is a closed surface (a solid)")
      .def_readonly("reference_cut_faces", &fe::Result::reference_cut_faces, "1-based reference faces treated as cut and not searched")
      .def_readonly("reference_cut_triangles", &fe::Result::reference_cut_triangles)
      .def_readonly("reference_cut_sides", &fe::Result::reference_cut_sides,
                    "sides of the reference's box ('-x' ... '+z') where it was cut out; the 20 % next to them is context")
      .def("to_json", [](const fe::Result& r) { return fe::result_to_json(r); }, "the CLI's result JSON");

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

  m.def("tessellation_for_feature", [](double L) {
    const auto o = fe::tessellation_for_feature(L);
    return py::make_tuple(o.relative_deflection, o.absolute_deflection);
  }, "(relative, absolute) deflection to read a target searched for a feature of diagonal L");

  // --- FE meshes and their transfer onto found instances (issue 5)
  auto quality_arrays = [](const std::vector<fe::ElementQuality>& q) {
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
  };
  auto summary_dict = [](const fe::QualitySummary& q) {
    py::dict d;
    d["elements"] = q.elements;
    d["inverted"] = q.inverted;
    d["min_scaled_jacobian"] = q.min_scaled_jacobian;
    d["median_scaled_jacobian"] = q.median_scaled_jacobian;
    d["max_aspect_ratio"] = q.max_aspect_ratio;
    d["median_aspect_ratio"] = q.median_aspect_ratio;
    d["min_angle_deg"] = q.min_angle_deg;
    return d;
  };
  py::class_<fe::FeMesh>(m, "FeMesh", "A finite-element mesh (S3/S4 shells, C3D4/C3D8 solids) with named node and element sets.")
      .def_readonly("nodes", &fe::FeMesh::nodes, "(N, 3) node coordinates")
      .def_readonly("node_ids", &fe::FeMesh::node_ids, "external node ids")
      .def_readonly("node_sets", &fe::FeMesh::node_sets, "name -> 0-based node indices")
      .def_readonly("element_sets", &fe::FeMesh::element_sets, "name -> 0-based element indices (blocks in order)")
      .def_property_readonly("num_elements", &fe::FeMesh::num_elements)
      .def_property_readonly("blocks", [](const fe::FeMesh& x) {
        py::list out;
        for (const auto& b : x.blocks) out.append(py::make_tuple(fe::inp_type_name(b.type), b.ids, b.conn, b.elset));
        return out;
      }, "[(type 'S3'|'S4'|'C3D4'|'C3D8', external ids, (n, k) 0-based node indices, elset name)]");
  m.def("read_fe_mesh", &fe::read_fe_mesh, py::arg("path"), "Reads a .inp or .msh mesh (raises InputError naming the file).");
  m.def("write_inp", &fe::write_inp, py::arg("mesh"), py::arg("path"));
  m.def("write_msh", &fe::write_msh, py::arg("mesh"), py::arg("path"), "gmsh ASCII 4.1");
  m.def("element_quality", [quality_arrays](const fe::FeMesh& x) { return quality_arrays(fe::element_quality(x)); }, py::arg("mesh"),
        "Per element: aspect_ratio, scaled_jacobian, min_angle_deg, inverted (numpy arrays).");
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
      .def_property_readonly("quality_before", [quality_arrays](const fe::TransferredMesh& t) { return quality_arrays(t.before); })
      .def_property_readonly("quality_after", [quality_arrays](const fe::TransferredMesh& t) { return quality_arrays(t.after); })
      .def_property_readonly("summary_before", [summary_dict](const fe::TransferredMesh& t) { return summary_dict(t.before_summary); })
      .def_property_readonly("summary_after", [summary_dict](const fe::TransferredMesh& t) { return summary_dict(t.after_summary); })
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
