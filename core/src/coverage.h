// Internal: the target region an accepted hypothesis covers: its dense samples, center and box, and
// the B-rep faces (or, for mesh input, the triangles) the mapped reference lies on.
#pragma once

#include "description.h"
#include "featureextract/result.h"

#include <vector>

namespace fe {

/// A found instance: its match, and the target dense samples it covers (sorted), which tell
/// overlapping instances apart (merge.h).
struct Instance {
  Match match;
  std::vector<int> covered;
  /// Target faces the instance lies on over at least kTouchedShare of their area (by dense samples
  /// within cover_target's merge_reach, faces of 20 samples or more), sorted: two fits of a smaller
  /// reference sliding along one longer instance each cover part of the same faces, too little of
  /// them to list them (merge.h).
  std::vector<int> touched;
};

/// The share of a target face's area an instance must cover to count as lying on it (Instance::touched).
constexpr double kTouchedShare = 0.25;

/// Fills inst.covered, and inst.match's center, bbox, faces and (mesh input) triangles from the mapped
/// reference samples `mapped` (kd-tree `mapped_tree`): a target sample or triangle centroid within
/// `reach` of them is the instance's (center, box; a B-rep face is listed when covered over
/// `face_coverage` of its area); inst.covered, which tells overlapping instances apart, holds the
/// samples within `merge_reach` (<= reach: an exact fit of a passage must not take the one 0.8 mm
/// above it). False when nothing is within reach.
bool cover_target(const Points& mapped, const KdTree3& mapped_tree, double reach, double merge_reach, const ShapeDescription::Impl& T,
                  const TriangleMesh& tmesh, double face_coverage, Instance& inst);

}  // namespace fe
