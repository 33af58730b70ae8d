// Internal: steps 4 and 5 of the paper (key point pairs, SI filter, Euclidean clusters).
#pragma once

#include "featureextract/mesh.h"
#include "shot.h"

#include <functional>
#include <vector>

namespace fe {

struct KeyPointPair {
  int ref = -1;        ///< reference key point index
  int tgt = -1;        ///< target key point index
  int shift = 0;       ///< SHOT radius shift: target radius = reference radius * ratio^shift
  float distance = 0;  ///< SHOT distance (per radius, RMS over the radii compared)
};

/// C_SHOT: for each target key point the N nearest reference key points over the multi-radius SHOT
/// descriptors, comparing the reference's radii [0, m) with the target's [s + D, s + D + m) for every
/// shift s in [-D, U] (target's ladder starts D steps below the reference's smallest radius).
std::vector<KeyPointPair> shot_pairs(const ShotSet& ref, const ShotSet& tgt, int m, int D, int U, int N,
                                     const std::function<bool(double)>& progress);

/// C_SI: the M reference key points nearest in shape index to each target key point, none farther
/// than max_difference (sharp creases, offset by kCreaseShapeIndex, never pair with smooth shapes).
std::vector<std::vector<int>> si_pairs(const Eigen::VectorXd& ref_si, const Eigen::VectorXd& tgt_si, int M,
                                       double max_difference = 0.5);

/// C_SS: keeps (j, i) in C_SHOT if some (n, m) in C_SI has |k_i - k_m| < delta_tgt and |k_j - k_n| < delta_ref.
/// delta_tgt is scaled by ratio^shift of the pair (a scaled target has scaled distances).
std::vector<KeyPointPair> filter_by_shape_index(const std::vector<KeyPointPair>& shot, const Points& ref_keys,
                                                const Points& tgt_keys, const std::vector<std::vector<int>>& si,
                                                double delta_ref, double delta_tgt, double ratio);

/// Euclidean clusters (single linkage with tolerance) of points; each cluster lists point indices.
std::vector<std::vector<int>> euclidean_clusters(const Points& points, double tolerance);

/// Placement voting (issue 9, many instances on one connected part): each pair, with its rotation
/// (reference -> target, from the local reference frames) and scale estimate, predicts where the
/// reference's center lands on the target: t + s R (c - r). Pairs of one instance agree, pairs of two
/// instances that touch through fillets do not. Greedy peaks of the votes (cells of `cell`, summed over
/// 3 x 3 x 3), each taking the pairs whose vote lies within `reach` x scale of the peak, largest first;
/// groups smaller than `min_pairs` are dropped. Returns indices into `votes`.
std::vector<std::vector<int>> vote_groups(const Points& votes, const std::vector<double>& scales, double cell,
                                          double reach, int min_pairs);

}  // namespace fe
