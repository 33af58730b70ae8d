// Internal: how a hypothesis (a 4x4 transform from the reference into the target) is scored and
// judged (the paper's section 3.8 and 4.2, and the checks issue 9 added). RANSAC and the one-pair
// placements select by cost(); the refinement follows it; a refined hypothesis is accepted when it
// passes every check of evaluate(), one check per acceptance bound.
#pragma once

#include "description.h"
#include "featureextract/clearance.h"
#include "featureextract/geometry.h"
#include "featureextract/reference.h"
#include "symmetry.h"

#include <Eigen/Core>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace fe {

/// How far apart H's largest and smallest stretch may be for an axisymmetric reference's key points
/// to agree at any turn about its axis (HypothesisScorer::key_agrees): nearly a similarity.
constexpr double kTurnRoundness = 1.2;

/// The part of a box-cut reference that is feature (issue 9): a user's box takes some of the part
/// around the feature too, and that context need not be the same around every instance (FTC-10's
/// ears: 4 of 4 found with a tight box, 2 of 4 with a box 20 % larger). Samples within
/// kContextMargin of the extent of a cut side of the box are context: hypotheses are judged, refined
/// and validated on the rest (the core). Not set: everything is feature (picked faces, an open STL
/// region).
struct FeatureCore {
  bool set = false;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(-INFINITY), hi = Eigen::Vector3d::Constant(INFINITY);
  /// When given, it decides instead of the box: per dense sample of the reference, 0 = context,
  /// 1 = feature, 2 = feature whose face was cut short (not held to the whole-faces check). Key points
  /// take their nearest dense sample's. (The faces a topology match holds, topology.h.)
  std::shared_ptr<const std::vector<char>> dense_feature;
  /// Points along the reference's open border (open_border_points), in the reference's frame. The
  /// B-rep faces they lie on (open_border_face) reach the border, so they may run past the end of
  /// their face on an instance, on their side toward the border (HypothesisScorer::overhangs).
  std::shared_ptr<const Points> open_border;
  std::shared_ptr<const std::vector<int>> open_border_face;  ///< the B-rep face of each open_border point
  /// Where a clipped mesh region passes through between two planes of its box, left out as the part's
  /// own faces (CutFaces::own_triangle, through_rims): the points where the feature met those planes,
  /// in the reference's frame, and the planes' outward normals. On an instance the feature may go on
  /// past them only where it leaves the part there (HypothesisScorer::through_share).
  std::shared_ptr<const Points> through_ends, through_outward;
  bool contains(const Eigen::Vector3d& x) const { return (x.array() >= lo.array()).all() && (x.array() <= hi.array()).all(); }
};
constexpr double kContextMargin = 0.2;
FeatureCore feature_core(const TriangleMesh& reference, const CutFaces& cut);

/// A target face covered less than this by the mapped reference is only partly the feature's
/// (the whole-faces check): a step on 40 % of a slot's floor; a boss of other proportions covers 70 %.
constexpr double kWholeFaceFill = 0.6;

/// The first bound of Params that a deformation breaks ("reflection", "volume_ratio", "axis_scale",
/// "anisotropy", "perspective", or "degenerate" for a map that folds or leaves the finite), or
/// nullptr when it is within all of them.
const char* deformation_outside(const Deformation& df, const Params& p);

/// One acceptance check: a measured value against its bound.
struct Check {
  const char* name;  ///< the Params bound it applies ("accept_error", "min_score", ...)
  double value, bound;
  bool passed;
};

/// What a hypothesis was judged on.
struct Evidence {
  double error = INFINITY;  ///< acceptance error (error_quantile of the point errors), reference units
  double tolerance = 0;     ///< accept_error L s: the error allowed in the target's units
  double score = 0;         ///< share of the mapped dense samples on the target, normals agreeing
  double key_agreement = 0; ///< share of the core key points landing near target key points of similar SI
  double obstructed = 0;    ///< Clearance::obstructed (0 when not measured)
  double partial_faces = 0; ///< FaceCoverCheck::partial_share (0 when not measured)
  double overhang = 0;      ///< share of the mapped dense samples that run past the end of the target's surface (overhangs)
  double rms = 0;           ///< RMS distance of the mapped dense samples to the target, target units
  Deformation deformation;
  Points mapped;            ///< the mapped dense subsample (HypothesisScorer::dense_rows)
  std::vector<Check> checks;  ///< in order; the expensive ones only when the cheap ones pass (or asked)

  bool accepted() const;
  /// Name of the first failed check, or "" when accepted.
  std::string failed() const;
};

/// Scores and judges hypotheses of one reference on one target. Safe to call from several threads
/// (cost, screen_cost). Holds references to both descriptions and the parameters.
class HypothesisScorer {
 public:
  HypothesisScorer(const ShapeDescription::Impl& R, const ShapeDescription::Impl& T, const Params& p, const FeatureCore& core);
  HypothesisScorer(const HypothesisScorer&) = delete;
  HypothesisScorer& operator=(const HypothesisScorer&) = delete;
  ~HypothesisScorer();

  /// H within the deformation bounds of Params (deformation_outside); its scale (cube root of the
  /// volume ratio) in *scale.
  bool bounds_ok(const Eigen::Matrix4d& H, double* scale) const;

  /// Selection cost (RANSAC, refinement): mean point error truncated at the normal penalty (MSAC),
  /// reference units; +inf out of bounds, off the target, or as soon as it cannot come under `limit`.
  double cost(const Eigen::Matrix4d& H, double limit = INFINITY) const;
  /// The truncated mean error over 40 of the evaluation points at scale s, no bounds test (one-pair
  /// placements, before the refinement brings them within the bounds) and no overhang test (a sample
  /// past the end of the target counts as off it); +inf as soon as the mean is sure to exceed `limit`
  /// (the sum only grows), the exact value otherwise.
  double screen_cost(const Eigen::Matrix4d& H, double s, double limit = INFINITY) const;
  /// Acceptance error (paper 3.8: the maximum; error_quantile < 1: that quantile), reference units.
  double quantile_error(const Eigen::Matrix4d& H) const;
  /// RMS distance of the mapped reference (dense subsample) to the target surface, target units.
  /// `coarse`: on a third of those samples (the spin search's many turns).
  double rms_on_surface(const Eigen::Matrix4d& H, bool coarse = false) const;

  /// Every acceptance check of H at scale s. With `all`, the expensive checks (free space, whole
  /// faces) are measured even after a cheap one failed (for the debug trace).
  Evidence evaluate(const Eigen::Matrix4d& H, double s, bool all = false) const;

  /// Distance from y to the nearest target dense sample (its index in *j).
  double target_distance(const Eigen::Vector3d& y, int* j = nullptr) const;

  /// Does a reference sample of a face that reaches the reference's border (FeatureCore::open_border),
  /// mapped to y with unit normal nm, off the target (farther than the acceptance tolerance from its
  /// nearest target sample j, or with another facing), run on past the end of the target's surface? It does when y lies in free space (in
  /// front of its nearest target samples, none behind) and on the continuation of a target surface of
  /// the same facing: the tangential step from y toward j ends beside target samples whose tangent
  /// planes pass through y. A bolt hole's cylinder picked in a thick wall, mapped onto a hole through
  /// a thinner one, runs on below the part; a hole of the wrong radius lies off its wall along the
  /// normal, and a rib sunk into a plate lies behind the plate's face: neither overhangs. Such samples
  /// are left out of the errors, the score and the RMS, up to Params::max_overhang of them.
  bool overhangs(const Eigen::Vector3d& y, const Eigen::Vector3d& nm, int j, double s) const;
  /// Where the nearest target sample j to the mapped sample y (mapped normal nm, error e in reference
  /// units) faces the opposite way while y lies on the surface, the coincident surface within two
  /// sample spacings that faces nm's way, if there is one (touching solids): e and j replaced by its.
  void facing(const Eigen::Vector3d& y, const Eigen::Vector3d& nm, double s, double& e, int& j) const;
  /// Per reference dense sample: on a face that reaches the border (overhangs() may apply).
  bool open_dense(Eigen::Index i) const { return !open_dense_.empty() && open_dense_[static_cast<std::size_t>(i)]; }

  /// The reference's axis of revolution, when its core is a surface of revolution (symmetry.h).
  const Symmetry& symmetry() const { return sym_; }
  /// An axisymmetric reference and H nearly a similarity: its stretches at the middle of the key
  /// points within kTurnRoundness of each other (key_agrees may then turn key points).
  bool turns_freely(const Eigen::Matrix4d& H) const;

  double normal_penalty() const { return normal_penalty_; }
  const std::vector<Eigen::Index>& core_keys() const { return core_keys_; }
  const std::vector<Eigen::Index>& core_dense() const { return core_dense_; }
  const std::vector<Eigen::Index>& dense_rows() const { return dense_rows_; }
  const Eigen::Vector3d& key_box_min() const { return rlo_; }
  const Eigen::Vector3d& key_box_max() const { return rhi_; }
  /// The whole-faces check (reference == nullptr when the shapes have no B-rep faces, or it is off).
  const FaceCoverCheck& whole_faces() const { return whole_faces_; }
  /// Per target face: up to 150 of its dense samples (the refinement's reverse pairs).
  const std::vector<std::vector<int>>& target_face_samples() const { return face_rows_; }

 private:
  double point_error(const Eigen::Matrix4d& H, Eigen::Index i, double s, bool capped, bool overhang = true) const;
  bool point_errors(const Eigen::Matrix4d& H, double s, double sum_limit, std::vector<double>& errs, bool capped) const;
  double overhang_share(const std::vector<double>& errs) const;
  /// Does dense sample `row` of the reference, mapped by H (at scale s) to y at distance e from its
  /// nearest target sample j, overhang (overhangs())?
  bool dense_overhangs(const Eigen::Matrix4d& H, Eigen::Index row, const Eigen::Vector3d& y, double e, int j, double s) const;

  const ShapeDescription::Impl& R_;
  const ShapeDescription::Impl& T_;
  const Params& p_;
  double L_;
  std::vector<Eigen::Index> core_keys_, core_dense_, dense_rows_, coarse_rows_, screen_rows_;
  std::vector<char> open_dense_, eval_open_;  // per R.dense row / per eval point: may overhang
  std::vector<double> border_dist_, eval_border_dist_;  // distance to the reference's open border (open rows)
  std::vector<int> eval_face_;                          // reference face of each eval point
  /// The truncation rule: per reference face, the overhanging entries (kOverhang in errs) must all
  /// lie nearer the reference's open border than the entries on the target (errs <= on); a face whose
  /// overhang reaches past them (a through step's floor laid over a triangular step, the rest of the
  /// rectangle beyond the diagonal) is not cut short at its border: its entries become `penalty`.
  void keep_truncations(std::vector<double>& errs, const std::vector<int>& face, const std::vector<double>& dist, double on, double penalty) const;
  Points eval_pts_, eval_nrm_;  // reference key points and dense samples that judge a transform
  double normal_penalty_;
  Eigen::Vector3d rlo_, rhi_;
  std::unique_ptr<Clearance> clearance_;
  FaceCoverCheck whole_faces_;
  std::vector<std::vector<int>> face_rows_;
  /// Per reference cylinder that reaches the open border across its end: its border points there and,
  /// at each, the direction in which it goes on past it (along its axis, outward); and its dense rows.
  struct BorderEnd {
    Points points, outward;
    std::vector<Eigen::Index> rows;
  };
  std::map<int, BorderEnd> border_ends_;
  std::vector<std::vector<int>> target_face_all_;  // every target dense row, per target face
  /// FaceCoverCheck::goes_on_through: target face g goes on past the mapped end of reference cylinder f
  /// at the open border (every sample of g that f does not cover lies past it), and where g ends,
  /// the part's surface faces the way g went (it leaves the part: a through hole's exit), not back
  /// (a pocket's far wall, a blind hole's floor).
  bool goes_on_through(const Eigen::Matrix4d& H, int f, int g) const;
  /// The core of goes_on_through, with the ends B (outward U) and the covering samples Y already
  /// mapped: 1 when every sample of target face g that Y does not cover (within `cover`) lies past the ends and the
  /// part's surface where g ends faces ahead, 0 when not, -1 when Y covers g whole. `f` names the
  /// reference face in the debug trace (0: a clipped region's through ends).
  int goes_on_past(const Points& B, const Points& U, const Points& Y, double cover, int g, int f) const;
  /// A clipped region that passes through between two planes of its box (FeatureCore::through_ends):
  /// where H puts the points where it met them, each must lie on the plane (target samples facing the
  /// plane's outward way, none more facing back), or on target faces that go on across it, each
  /// covered for kWholeFaceFill by the mapped reference or going on past the end and leaving the part
  /// there (goes_on_past), or in free space beyond a surface facing the outward way. The share of those points that do
  /// neither (0 when not measured): a hole through a wall, clipped out of an STL, laid on the first
  /// part of a blind hole. `tol`: the acceptance tolerance (half of it widens the search around each).
  double through_share(const Eigen::Matrix4d& H, double tol) const;
  Points through_ends_, through_outward_;
  std::vector<Eigen::Index> through_rows_;  // dense rows that cover a target face (stride subset of the core)
  std::unique_ptr<KdTree3> tkey_tree_;
  Symmetry sym_;
  /// Key point agreement of reference key point i under H: a target key point of a similar shape
  /// index lies within `reach` of where H puts it or, with `turns` (turns_freely(H)), of where H puts
  /// any turn of it about the reference's axis (s: H's scale).
  bool key_agrees(const Eigen::Matrix4d& H, Eigen::Index i, double reach, double s, bool turns, std::vector<int>& near, std::vector<float>& d2) const;
};

}  // namespace fe
