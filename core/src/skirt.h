#pragma once
// A reference's open border, continued: a band of surface beyond each open edge, in the plane of the
// edge's triangle, used as descriptor support only (never sampled for key points, never judged).
#include "featureextract/mesh.h"

namespace fe {

/// The skirt of `m`: for every open edge (used by one triangle, vertices welded by position), a quad
/// `width` wide that leaves the edge in its triangle's plane, away from the triangle, oriented like
/// it. At a border vertex the quads of its two edges leave along their mean direction, so the band
/// is one strip round the border. Empty (no triangles) for a closed mesh.
TriangleMesh border_skirt(const TriangleMesh& m, double width);

}  // namespace fe
