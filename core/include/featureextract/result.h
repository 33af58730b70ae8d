// What an extraction returns (issue 2, "Result per found instance").
#pragma once

#include "featureextract/params.h"

#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

namespace fe {

/// Match::face_shares lists the faces covered for at least this share of their area.
constexpr double kFaceShareFloor = 0.05;

struct Match {
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();  ///< H: reference -> target, h44 = 1
  double score = 0;       ///< fraction of mapped reference samples lying on the target, in [0, 1]
  double max_error = 0;   ///< max distance of mapped reference key points to the target surface
  double rms_error = 0;   ///< RMS distance of mapped reference dense samples to the target surface
  double rms_error_unrefined = 0;  ///< the same for the transform before the surface refinement
  double scale = 1;       ///< cube root of the volume ratio of the linear part of H
  Eigen::Vector3d center = Eigen::Vector3d::Zero();  ///< center of the matched target region
  Eigen::Vector3d bbox_min = Eigen::Vector3d::Zero();
  Eigen::Vector3d bbox_max = Eigen::Vector3d::Zero();
  std::vector<int> faces;      ///< 1-based target FaceN covered by the mapped reference (B-rep input)
  /// (FaceN, share of its area covered) for every target face covered for at least kFaceShareFloor
  /// of its area, by face (B-rep input): `faces` are those at Params::face_coverage or more, the rest
  /// are the faces the instance only reaches into (a fillet beside it)
  std::vector<std::pair<int, double>> face_shares;
  std::vector<int> triangles;  ///< 0-based target triangles covered (mesh input)
  int pairs = 0;               ///< key point pairs consistent with H
  double key_agreement = 0;    ///< fraction of reference key points landing near target key points of similar SI
  double stretch_min = 1, stretch_max = 1;  ///< smallest and largest singular value of H's Jacobian at the feature's center
  double perspective = 0;      ///< largest |w - 1| of H over the reference feature's box
  double obstructed = 0;       ///< fraction of the reference's free-space rays that meet target surface (see clearance.h)
  double overhang = 0;         ///< fraction of the mapped reference that runs past the end of the instance's surface (Params::max_overhang)
  bool mirrored = false;       ///< found by the mirror image of the reference: det of H's linear part < 0
};

struct ShapeStats {
  std::size_t triangles = 0, faces = 0, dense_points = 0, sparse_points = 0, key_points = 0,
              descriptors = 0, dropped_degenerate = 0;
  double diagonal = 0;
};

struct Result {
  std::vector<Match> matches;
  ShapeStats reference, target;
  double feature_size = 0;  ///< L: reference bounding-box diagonal, unit of relative parameters
  std::size_t pairs_shot = 0, pairs_ss = 0, clusters = 0;
  std::size_t topology_matches = 0;  ///< matches of the reference's faces on the target's (topology_hypotheses)
  std::size_t ransac_searches = 0;   ///< RANSAC searches run on the clusters' pairs, unguided retries included: most of what a feature that is not on the part costs
  std::vector<std::pair<std::string, double>> timings;  ///< stage -> seconds, in order
  std::vector<std::string> warnings;
  Params params;
  /// Symmetry found in the reference: "none" or "axisymmetric" (then the axis through symmetry_point
  /// along symmetry_axis; each instance's free spin about it is fixed to the least twisted one).
  std::string symmetry = "none";
  Eigen::Vector3d symmetry_point = Eigen::Vector3d::Zero(), symmetry_axis = Eigen::Vector3d::Zero();
  bool mirror_searched = false;         ///< the mirror image of the reference was searched too
  bool reference_mirror_symmetric = false;  ///< the reference is its own mirror image (no mirrored search needed)
  bool reference_closed = false;        ///< the reference is a closed surface (a solid)
  std::vector<int> reference_cut_faces; ///< 1-based reference faces treated as cut (not searched)
  std::vector<int> reference_own_faces; ///< 1-based box faces found on the target's surface where the reference was cut out of it: the part's own, not cut (not searched either; Params::cut_faces_on_target)
  std::size_t reference_cut_triangles = 0;
  /// Sides of the reference's bounding box ("-x" ... "+z") where it was cut out (cut faces, or an
  /// open mesh region's border): the 20 % of the reference next to them is judged as context.
  std::vector<std::string> reference_cut_sides;
};

/// The JSON document of the CLI contract (README, "Result JSON").
std::string result_to_json(const Result& r, int indent = 2);

}  // namespace fe
