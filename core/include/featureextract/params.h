// Parameters of the extraction, with their defaults. Lengths are fractions of the reference
// feature's bounding-box diagonal L ("feature size"), so one set of defaults serves a 5 mm boss and
// a 500 mm bracket. The table in params.cpp documents each one (CLI --help, JSON, Python docstrings).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace fe {

struct Params {
  // --- reproducibility and resources
  std::uint64_t seed = 1;        ///< seed of sampling and RANSAC; same input + seed = same output
  int threads = 0;               ///< worker threads for SHOT; 0 = all cores
  double time_limit = 0;         ///< seconds; a longer extraction stops with TimeLimitExceeded; 0 = no limit

  // --- step 1: sampling (x L)
  double dense_spacing = 0.014;  ///< spacing of the dense samples (support of descriptors, validation)
  double sparse_spacing = 0.035; ///< spacing of the sparse samples (candidate key points)
  std::size_t max_dense_points = 2000000;  ///< cap; beyond it reference and target are both described coarser (with a warning)
  int size_ladder = 0;  ///< if > 0, L is rounded to the nearest size 2^(k / size_ladder), so that features of nearby sizes share the target's descriptions (the library search: 3, the SHOT radius ladder's step); 0 = L exactly

  // --- step 2: descriptors (x L unless said otherwise)
  double normal_radius = 0.035;     ///< PCA normal support radius
  double curvature_radius = 0.045;  ///< quadric-fit support radius for principal curvatures
  double planar_curvedness = 1.5;   ///< curvedness * L below which a point is planar (SI = -1)
  double shot_radius = 0.10;        ///< smallest SHOT support radius
  int shot_radii = 3;               ///< number of SHOT radii per descriptor (paper: multiple radii)
  double shot_radius_ratio = 1.26;  ///< ratio between consecutive SHOT radii (also the scale step)
  bool border_skirt = false;        ///< a reference's open border is continued (skirt.h) in the support of its normals, shape index and SHOT (off: see docs/benchmarks.md)
  double scale_min = 0.8;           ///< smallest instance/reference scale searched; below 0.8 in scale bands (extract())
  double scale_max = 2.6;           ///< largest instance/reference scale searched; above 2.6 in scale bands

  // --- step 3: key points (shape index bands)
  double si_band = 0.07;  ///< half-width of the rut (0.25) and ridge (0.75) bands that are not key points
  double ridge_rut_spacing = 0.0;  ///< (x L) if > 0, ridge and rut points are key points too, one per cube of this size
  bool crease_key_points = true;   ///< sharp edges and corners (planes meeting) get the shape index of the rounded crease
  double ridge_rut_fallback = 0.05;  ///< (x L) if nothing is found, search again with ridge_rut_spacing this; 0 = never

  // --- step 4: pairs
  int shot_neighbours = 6;      ///< N: nearest reference key points in SHOT space per target key point
  int si_neighbours = 12;       ///< M: nearest reference key points in SI per target key point
  double pair_distance = 0.06;  ///< delta (x L): SHOT pair kept if an SI pair lies this close at both ends

  // --- step 5: clusters (x L)
  double cluster_tolerance = 2.0;  ///< Euclidean clustering tolerance of paired target key points
  int min_cluster_pairs = 5;       ///< clusters with fewer pairs are dropped
  double vote_reach = 0.0;         ///< (x L x scale) placement votes this close to a peak form one instance's group; 0 = clusters only (paper)

  // --- step 6: RANSAC projective transform
  int ransac_max_iterations = 4000;  ///< upper bound of iterations per instance search
  int ransac_patience = 600;         ///< stop after this many iterations without improvement
  bool pose_hypotheses = true;       ///< also try one placement per pair (rotation from local frames, scale from SHOT) against RANSAC's
  bool ransac_unguided_retry = true;  ///< a rejected hypothesis is sought again around it with RANSAC samples not guided by the local frames
  bool topology_hypotheses = true;   ///< also try affine maps from matching how the reference's faces meet (issue 9: machined features)
  int refine_iterations = 30;        ///< surface refinement (ICP-like) iterations after RANSAC; 0 = paper
  int max_failures = 8;              ///< a cluster is given up after this many rejected transforms in a row
  int max_far_failures = 2;          ///< ... or, before its first instance, after this many in a row whose error is at its cap (2 x accept_error); 0 = off
  double error_quantile = 0.9;        ///< 1.0 = paper's maximum error; < 1 = that quantile (robust)
  double accept_error = 0.05;        ///< accept if that error <= this x L x scale
  double min_score = 0.6;            ///< accept if this fraction of the mapped reference lies on the target
  double min_key_agreement = 0.5;    ///< accept if this fraction of reference key points lands near target key points of similar SI
  double max_obstructed = 0.2;       ///< accept if at most this fraction of the reference's free-space rays meets target surface (1 = off)
  double clearance_margin = 0.08;    ///< free-space rays run this far (x L) past the reference's box
  double max_partial_faces = 0.2;    ///< accept if at most this share of the reference's whole faces lands on part of a larger target face (1 = off)
  double max_overhang = 0.5;         ///< at most this share of the mapped reference may run past the end of the target's surface where the reference's face reaches its border (a bolt hole through a thinner wall); 0 = none
  double key_si_tolerance = 0.125;   ///< shape index difference allowed for that agreement
  double volume_ratio_min = 0.2;     ///< bounds of |det| of the linear part (volume expansion ratio)
  double volume_ratio_max = 20.0;
  double axis_scale_min = 0.5;       ///< bounds of each singular value of the linear part
  double axis_scale_max = 3.2;
  double max_anisotropy = 3.0;       ///< largest / smallest singular value (oblique distortion)
  double max_perspective = 0.25;     ///< largest |w - 1| over the reference feature's box
  bool allow_reflection = false;     ///< accept transforms with negative determinant (mirror images)
  double topology_axis_scale_min = 0.25;  ///< axis_scale_min for hypotheses from a topology match (every face matched)
  double topology_axis_scale_max = 4.0;   ///< axis_scale_max for them
  double topology_max_anisotropy = 8.0;   ///< max_anisotropy for them

  // --- references as users make them (issue 9)
  bool mirror = true;            ///< also search the reference's mirror image (unless it is its own); matches say "mirrored"
  bool detect_cut_faces = true;  ///< a closed reference (cut out with a box) is searched without its cut faces
  bool cut_faces_on_target = true;  ///< of those, the ones on the target's surface where the reference sits on it unmoved are kept (the part's own faces)

  // --- result
  double face_coverage = 0.5;  ///< a target face is listed if this fraction of it is covered
  double max_overlap = 0.3;    ///< instances sharing more of their region than this are merged

  /// Throws std::invalid_argument naming the first parameter out of its range.
  void validate() const;
};

/// One documented parameter, for --help, JSON, the bindings and the task panel's groups. The table
/// lists them step by step; the JSON names stay flat.
struct ParamInfo {
  std::string name;
  std::string type;   ///< "int", "float", "bool", "uint64"
  std::string unit;   ///< "x L", "", "count", ...
  std::string help;
  std::string default_value;
  std::string group;  ///< the paper's step it belongs to ("1. Sampling", ..., "6. Acceptance"), or "Reference", "Result", "Run"
};
const std::vector<ParamInfo>& param_table();

/// Parameters as a JSON object text (all of them, as used).
std::string params_to_json(const Params& p);
/// Reads a JSON object; unknown keys and wrong types throw std::invalid_argument naming the key.
Params params_from_json(const std::string& json_text, const Params& base = {});

}  // namespace fe
