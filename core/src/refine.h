// Internal: the surface refinement of a hypothesis (issue 3 and 9). A RANSAC fit on five key points,
// or a one-pair placement, is refitted on the pairs it explains and then pulled onto the target's
// surface (ICP-like, point to plane, projective least squares); a second refinement with reverse
// pairs lets it grow over whole target faces; axisymmetric references get their symmetric fit.
#pragma once

#include "hypothesis.h"
#include "kdtree.h"
#include "symmetry.h"

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <memory>
#include <vector>

namespace fe {

/// A refined hypothesis.
struct Polished {
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
  double s = 1;              ///< scale of H (cube root of its volume ratio)
  double rms_unrefined = 0;  ///< RMS fit error before the surface refinement, target units
  double cost = INFINITY;    ///< HypothesisScorer::cost plus the reverse pairs' term (refinements compared)
  std::array<int, 5> sample{};  ///< the pairs it came from (RANSAC's sample, or the placement's pair)
};

class SurfaceRefinement {
 public:
  /// The refinement samples: up to 800 of the scorer's core dense samples; the reference's symmetry
  /// is detected on them.
  SurfaceRefinement(const ShapeDescription::Impl& R, const ShapeDescription::Impl& T, const Params& p, const HypothesisScorer& scorer);

  const Symmetry& symmetry() const { return sym_; }

  /// H0 (of cost cost0) refitted on the pairs (rp -> tp) it explains, refined on the surface, tight
  /// and grown over whole faces, and for an axisymmetric reference fitted with the symmetric model.
  Polished polish(const Eigen::Matrix4d& H0, double cost0, const Points& rp, const Points& tp) const;

  /// The reverse pairs' term: target samples of the faces that whole reference faces land on (H at
  /// scale s), to the nearest mapped reference sample; their mean distance in reference units
  /// (truncated at the normal penalty), 0 without faces. The pairs in ra (reference) and rb (target)
  /// when asked.
  double reverse_pairs(const Eigen::Matrix4d& H, double s, std::vector<Eigen::Vector3d>* ra, std::vector<Eigen::Vector3d>* rb) const;

 private:
  struct Refined {
    Eigen::Matrix4d H;
    double s, cost, reverse_start, reverse;
  };
  /// One refinement from H0; with `grow`, reverse pairs let it grow over whole target faces.
  Refined refine(const Eigen::Matrix4d& H0, double s0, bool grow) const;
  /// The target's border samples (next to another B-rep face) within reach of the reference's border
  /// mapped by H at scale s; null where the target has none there (a mesh target: one face).
  std::unique_ptr<KdTree3> target_border(const Eigen::Matrix4d& H, double s) const;
  /// Mean distance (reference units, truncated at the normal penalty) from the reference's border
  /// samples mapped by H to the nearest target border sample.
  double border_distance(const KdTree3& target_border, const Eigen::Matrix4d& H, double s) const;

  const ShapeDescription::Impl& R_;
  const ShapeDescription::Impl& T_;
  const Params& p_;
  const HypothesisScorer& scorer_;
  double L_;
  Points pts_, nrm_;         // refinement samples of the reference and their normals
  std::vector<int> face_;    // reference face of each (empty: no whole-face growth)
  double cell_ = 0;          // reference area per refinement sample
  Symmetry sym_;
  Points border_;            // axisymmetric reference: core samples next to another face or the open border
};

}  // namespace fe
