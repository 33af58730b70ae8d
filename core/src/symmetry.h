// Internal: symmetry detection and the symmetric fit (issue 5). An axisymmetric reference (a boss,
// a hole) leaves the spin about its axis free: RANSAC's pairs contradict each other there, and a
// general projective fit can drift into a skewed map. These find the axis and fit along it.
#pragma once

#include "description.h"

#include <Eigen/Core>
#include <cmath>

namespace fe {

/// On a surface of revolution every normal line meets the axis.
struct Symmetry {
  bool axisymmetric = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero(), axis = Eigen::Vector3d::UnitZ();
  double residual = INFINITY;  ///< RMS distance of the normal lines from the axis, in model units
};

/// The axis of revolution of samples x with normals n (L: the feature size, for the tolerances);
/// axisymmetric only when the normal lines meet one axis and turn around it (not a single plane).
Symmetry detect_axisymmetry(const Points& x, const Points& n, double L);

/// H composed with a spin of theta radians about the reference's axis (normalised, H(3, 3) = 1).
Eigen::Matrix4d spin(const Eigen::Matrix4d& H, const Symmetry& sym, double theta);

/// H composed with the spin about the reference's axis that makes H's linear part twist least, so
/// that instances come out without an arbitrary spin and the same input gives the same orientation.
Eigen::Matrix4d untwist(const Eigen::Matrix4d& H, const Symmetry& sym);

/// The symmetric model fit: the target's own axis (found near the mapped reference), then radial
/// scale, axial scale and axial offset by point-to-plane least squares, a few ICP rounds, from the
/// reference samples ref_pts / ref_nrm onto the target T. `size` is the mapped feature size. Returns
/// H unchanged when the target axis cannot be found.
Eigen::Matrix4d fit_axisymmetric(const Eigen::Matrix4d& H, const Symmetry& rs, const Points& ref_pts, const Points& ref_nrm,
                                 const ShapeDescription::Impl& T, double size);

}  // namespace fe
