// Low-level geometry of the method, public so that each can be tested alone (libigl style).
#pragma once

#include "featureextract/mesh.h"

#include <Eigen/Core>
#include <cstdint>
#include <array>
#include <functional>
#include <vector>

namespace fe {

// ---------------------------------------------------------------------------------------------
// Step 1. Area-weighted sampling on the triangles, thinned to a roughly uniform spacing (one point
// per cube of side `spacing`). Normals are the source triangles' (flat) normals. Deterministic for
// a seed. Zero-area triangles get no samples.
Samples sample_surface(const TriangleMesh& mesh, double spacing, std::uint64_t seed);

// Step 2a. Oriented normals by PCA over `radius` neighbours in `support` (only neighbours whose raw
// normal faces the same side, so both skins of a thin wall are kept apart), signs kept from the raw
// normals. Returns N x 3 for `query`.
Points estimate_normals(const Samples& support, const Samples& query, double radius);

// Step 2b. Signed principal curvatures k1 >= k2 at `query` points, from a least-squares quadric
// z = a x^2 + b xy + c y^2 + d x + e y + f in the tangent frame of each point's normal, fitted on
// `support` points within `radius` (same-side neighbours only). Outward normals: convex = negative.
// Rows with fewer than 6 neighbours get NaN.
Eigen::MatrixX2d principal_curvatures(const Points& support, const Points& support_normals,
                                      const Points& query, const Points& query_normals, double radius);

/// Special shape index value of planar points (paper section 3.4).
constexpr double kPlanarShapeIndex = -1.0;

/// Shape index of eq. (3.1) with k1 >= k2: 0 cup, 0.25 rut, 0.5 saddle, 0.75 ridge, 1 cap.
/// Returns kPlanarShapeIndex if the curvedness sqrt((k1^2 + k2^2) / 2) < planar_curvedness.
double shape_index(double k1, double k2, double planar_curvedness);

/// Step 2b for sharp creases, which a quadric fit over same-side neighbours takes for planes (machined
/// parts: planes meeting at edges and corners). Within `radius` of each query point, support points
/// whose raw normals turn 30-150 degrees from the query's (more: the other skin of a thin wall) lie on
/// other facets. The limit of the shape index as the crease is rounded off: 0.75 on a convex edge
/// (ridge), 0.25 on a concave one (rut); near a corner of two other facets 1 (cap, both convex),
/// 0 (cup, both concave) or 0.5 (saddle). NaN where no crease is within reach.
Eigen::VectorXd crease_shape_index(const Samples& support, const Samples& query, double radius);

/// Shape index values of sharp creases are kCreaseShapeIndex + crease_shape_index(): a sharp edge is
/// another shape than a filleted one, so the two never pair (the shape index filter and the key point
/// agreement compare values), while the bands below apply to both alike.
constexpr double kCreaseShapeIndex = 2.0;

/// Step 3: is a shape index value a key point (not plane, rut or ridge)? Crease values
/// (>= kCreaseShapeIndex) are judged by the same bands.
bool is_key_shape_index(double si, double band);

// ---------------------------------------------------------------------------------------------
// Step 6. Projective transforms X' = (H X) / w, H 4 x 4 with h44 = 1.

/// Applies H to a point (homogeneous divide). Returns NaN if w is ~0.
Eigen::Vector3d apply_transform(const Eigen::Matrix4d& H, const Eigen::Vector3d& p);

/// The 3 x 3 Jacobian of x -> apply_transform(H, x) at p (normals map by its inverse transpose).
Eigen::Matrix3d transform_jacobian(const Eigen::Matrix4d& H, const Eigen::Vector3d& p);

/// Solves eqs. (3.2)-(3.3) for the 15 unknowns from exactly 5 pairs (rows of ref -> tgt) by LU.
/// Points are normalized (mean 0, std 1) first and H de-normalized after (eq. 3.4).
/// Returns false if the system is singular (e.g. 4 coplanar points).
bool solve_projective_5(const Eigen::Matrix<double, 5, 3>& ref, const Eigen::Matrix<double, 5, 3>& tgt,
                        Eigen::Matrix4d& H);

/// Least-squares H from n >= 5 pairs (same linearization, normalized). False if ill-conditioned.
bool fit_projective(const Points& ref, const Points& tgt, Eigen::Matrix4d& H);

/// Affine least squares from n >= 4 pairs (H with last row 0 0 0 1).
bool fit_affine(const Points& ref, const Points& tgt, Eigen::Matrix4d& H);

/// Deformation measures of H over a box (paper section 4.2 bounds).
struct Deformation {
  double volume_ratio = 0;   ///< |det| of the linear part at the box center (Jacobian)
  double scale_min = 0;      ///< smallest singular value of the Jacobian
  double scale_max = 0;      ///< largest singular value
  double perspective = 0;    ///< max |w/w_center - 1| over the box corners
  bool reflection = false;   ///< det < 0
};
Deformation deformation(const Eigen::Matrix4d& H, const Eigen::Vector3d& box_min, const Eigen::Vector3d& box_max);

/// Generic RANSAC over pairs with the paper's minimal sample of 5 and a caller-given cost
/// (lower is better, +inf rejects). Samples are drawn around a random first pair: the other four
/// target points lie within `locality` of it (<= 0: anywhere). Stops after `patience` iterations
/// without improvement or at `max_iterations`.
struct RansacOptions {
  int max_iterations = 4000;
  int patience = 600;
  double locality = 0;
  /// If ratio_max > 0, every two pairs (a, b) of a sample must satisfy
  /// ratio_min <= |t_a - t_b| / |r_a - r_b| <= ratio_max (a necessary condition for bounded stretch).
  double ratio_min = 0, ratio_max = 0;
  /// Degeneracy test on the 5 points of a sample (either side), after normalization to unit RMS:
  /// if every 4-point tetrahedron has at least this volume the projective H is solved (paper);
  /// if only some do, 4 points are nearly coplanar and an affine H is fitted to the 5 pairs;
  /// if none do, the sample is skipped.
  double min_tetra_volume = 0.02;
  /// Optional per-pair rotations (reference -> target, e.g. from local reference frames). When given,
  /// the other four pairs of a sample must agree with the first pair's rotation: the angle between
  /// t_c - t_first and R_first (r_c - r_first) at most max_angle (radians). This keeps a sample within
  /// one placement of a symmetric feature instead of mixing its mirror images.
  const std::vector<Eigen::Matrix3d>* rotations = nullptr;
  double max_angle = 0.6;
  /// Optional per-pair scale estimates (e.g. from the SHOT radius shift). When given, a sample around
  /// first pair f uses locality * scale_f and distance ratios within [scale_f / 2, 2 scale_f]
  /// (intersected with [ratio_min, ratio_max]).
  const std::vector<double>* scales = nullptr;
  /// Fit an affine H (least squares on the 5 pairs) for every sample instead of the projective solve.
  bool affine_only = false;
  std::uint64_t seed = 1;
  /// Hypotheses drawn ahead and scored together, on all OpenMP threads when > 1 (the cost must then
  /// be safe to call concurrently). The samples, the stopping rule and so the result are the same
  /// for every batch size and thread count; a batch only wastes the draws past the stop.
  int batch = 1;
};
struct RansacResult {
  bool found = false;
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
  double cost = 0;
  int iterations = 0;
  int affine_samples = 0;  ///< hypotheses that came from the affine fallback
  std::array<int, 5> sample{{-1, -1, -1, -1, -1}};
  /// (iteration, cost) at each improvement of the best, in order (for traces).
  std::vector<std::pair<int, double>> improvements;
};
RansacResult ransac_projective(const Points& ref, const Points& tgt,
                               const std::function<double(const Eigen::Matrix4d&)>& cost,
                               const RansacOptions& options,
                               const std::function<bool()>& cancelled = {});
/// The same with a cost that is told the best cost so far (`limit`): it may return +inf as soon as it
/// knows its value cannot be below the limit, which changes nothing but the time.
RansacResult ransac_projective(const Points& ref, const Points& tgt,
                               const std::function<double(const Eigen::Matrix4d&, double limit)>& cost,
                               const RansacOptions& options,
                               const std::function<bool()>& cancelled = {});

}  // namespace fe
