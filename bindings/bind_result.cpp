// Bindings of featureextract/result.h.
#include "common.h"
#include "featureextract/result.h"

#include <pybind11/eigen.h>
#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <cmath>

namespace fe_py {

void bind_result(py::module_& m) {
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
      .def_readonly("face_shares", &fe::Match::face_shares, "(FaceN, covered share of its area) for every face covered for at least 5 % (B-rep input)")
      .def_readonly("triangles", &fe::Match::triangles, "0-based target triangles covered (mesh input)")
      .def_readonly("pairs", &fe::Match::pairs)
      .def_readonly("key_agreement", &fe::Match::key_agreement, "fraction of reference key points landing near target key points of similar shape index")
      .def_readonly("stretch_min", &fe::Match::stretch_min, "smallest singular value of H's Jacobian at the feature's center")
      .def_readonly("stretch_max", &fe::Match::stretch_max, "largest singular value of H's Jacobian at the feature's center")
      .def_readonly("perspective", &fe::Match::perspective, "largest |w - 1| of H over the reference feature's box")
      .def_readonly("obstructed", &fe::Match::obstructed, "fraction of the reference's free-space rays (along its outward normals) that meet target surface")
      .def_readonly("overhang", &fe::Match::overhang, "fraction of the mapped reference that runs on past the end of the instance's surface, where a reference face reaches the reference's border (a bolt hole through a thinner wall)")
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
      .def_readonly("reference_own_faces", &fe::Result::reference_own_faces, "1-based faces on the reference's box that lie on the target where the reference was cut out of it: the part's own faces, not cut (not searched either)")
      .def_readonly("reference_cut_triangles", &fe::Result::reference_cut_triangles)
      .def_readonly("reference_cut_sides", &fe::Result::reference_cut_sides,
                    "sides of the reference's box ('-x' ... '+z') where it was cut out; the 20 % next to them is context")
      .def("to_json", [](const fe::Result& r) { return fe::result_to_json(r); }, "the CLI's result JSON");
}

}  // namespace fe_py
