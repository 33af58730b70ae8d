// Internal: hypotheses from one key point pair each (issue 9). The pair's SHOT local frames give the
// rotation and its SHOT radius shift the scale. Where few pairs are right (a real part's one big
// cluster), RANSAC's 5-pair sample is rarely all right; one pair often is.
#pragma once

#include "hypothesis.h"
#include "pairing.h"

#include <Eigen/Core>
#include <cmath>
#include <vector>

namespace fe {

/// The SHOT local frames of a pair at the middle radius (the target's shifted by the pair's scale).
struct PairFrames {
  const ShotSet& reference;
  const ShotSet& target;
  int mid;  ///< the reference's middle radius
  int D;    ///< the target's ladder steps below the reference's radii
  Eigen::Matrix3d ref(const KeyPointPair& pr) const { return reference.frame(pr.ref, mid); }
  Eigen::Matrix3d tgt(const KeyPointPair& pr) const { return target.frame(pr.tgt, pr.shift + D + mid); }
  /// Rotates reference directions into the target.
  Eigen::Matrix3d rotation(const KeyPointPair& pr) const { return tgt(pr).transpose() * ref(pr); }
};

struct Placement {
  Eigen::Matrix4d H = Eigen::Matrix4d::Identity();
  double cost = INFINITY;  ///< HypothesisScorer::cost
  int pair = -1;           ///< the pair whose target point lies nearest the mapped one (-1: none found)
};

/// The best one-pair placement of a cluster's pairs (rp, tp: their reference and target key points;
/// scales: each pair's scale). SHOT's frame axes can flip sign: the four proper sign changes are
/// tried. At most 1500 pairs are placed, screened on a few evaluation points, and the best 24 scored
/// in full.
Placement one_pair_placement(const std::vector<KeyPointPair>& pairs, const Points& rp, const Points& tp,
                             const std::vector<double>& scales, const PairFrames& frames, const HypothesisScorer& scorer);

}  // namespace fe
