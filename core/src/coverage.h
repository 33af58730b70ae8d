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
};

/// Fills inst.covered, and inst.match's center, bbox, faces and (mesh input) triangles from the mapped
/// reference samples `mapped` (kd-tree `mapped_tree`): a target sample or triangle centroid within
/// `reach` of them is covered; a B-rep face is listed when covered over `face_coverage` of its area.
/// False when nothing is covered.
bool cover_target(const Points& mapped, const KdTree3& mapped_tree, double reach, const ShapeDescription::Impl& T,
                  const TriangleMesh& tmesh, double face_coverage, Instance& inst);

}  // namespace fe
