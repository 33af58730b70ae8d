// Internal: hypotheses from how the reference's regions meet (issue 9, machined features and
// instances of other proportions). The reference's feature regions (regions.h, without the context
// where it was cut out) are matched on the target's regions as a subgraph: the same kinds of
// surface (planar or not) meeting along edges of the same kind (convex, concave, about the same
// angle); a region the reference holds whole must be whole on the target too (no neighbour outside
// the match). Each match gives point correspondences, the corners where the same regions meet and
// the centroids of whole regions, and an affine transform fitted to them: a pocket 1.4 times as
// wide as the reference is matched corner for corner, where SHOT pairs of its plain walls and
// creases are ambiguous. The transforms are then judged like any other hypothesis (hypothesis.h).
#pragma once

#include "regions.h"

#include <Eigen/Core>
#include <cmath>
#include <vector>

namespace fe {

struct TopologyOptions {
  double angle_tolerance = 45.0 * M_PI / 180.0;  ///< dihedral angles of matched contacts differ by at most this (a V groove twice as wide turns by more than 30)
  std::size_t max_matches = 20000;               ///< subgraph matches enumerated at most
  std::size_t max_per_image = 24;                ///< matches onto one set of target regions (symmetries) fitted at most
  std::size_t max_hypotheses = 400;              ///< hypotheses returned at most (best fits first)
};

struct TopologyHypothesis {
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();  ///< affine, reference -> target
  double residual = 0;        ///< RMS distance of the fitted correspondences, target units
  int group = 0;              ///< hypotheses of one group map onto the same target regions (equally good fits)
  /// What lies beyond the group's regions agrees with the best group: no matched region's image meets
  /// a region outside the image along a sharp edge of a sense (convex, concave) that the best group's
  /// image of it does not. Where a picked through slot's floor ends, the part turns down (convex); a
  /// blind slot's floor ends at a wall (concave): not the same feature, though its faces match.
  bool border_agrees = true;
  std::vector<int> image;     ///< target region of each matched reference region (TopologyMatch::matched)
  Points ref_points, tgt_points;  ///< the correspondences it was fitted to
};

struct TopologyMatch {
  std::vector<int> matched;   ///< the reference regions matched: the largest connected set of uncut regions
  std::size_t matches = 0;    ///< subgraph matches found
  bool truncated = false;     ///< the enumeration stopped at max_matches
  std::size_t degenerate = 0; ///< matches whose correspondences could not fix an affine transform
  /// Per set of target regions (a group), its fits of lowest residual, equally good ones all kept
  /// (a passage's symmetries fit a turned passage as well); groups by residual, a group's fits
  /// proper and least stretched first.
  std::vector<TopologyHypothesis> hypotheses;
};

/// Matches `ref` (its cut regions are context, mark_cut) on `tgt`. Nothing when fewer than two
/// regions are left to match.
TopologyMatch topology_hypotheses(const RegionGraph& ref, const RegionGraph& tgt, const TopologyOptions& o = {});

/// The affine map (4 x 4) that best maps rows of a onto rows of b (least squares); false when the
/// rows of a do not span 3-D (fewer than 4 or nearly coplanar). RMS residual in *rms.
bool fit_affine(const Points& a, const Points& b, Eigen::Matrix4d* H, double* rms);

}  // namespace fe
