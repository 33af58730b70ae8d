// Internal: the curvature stages of geometry.h on a kd-tree the caller already has over the support
// points (describe() builds one tree over its dense samples and shares it with every stage; each
// public function builds its own). Same results as the public functions.
#pragma once

#include "featureextract/geometry.h"
#include "kdtree.h"

namespace fe {

/// estimate_normals with `tree` built over support.points.
Points estimate_normals(const KdTree3& tree, const Samples& support, const Samples& query, double radius);
/// principal_curvatures with `tree` built over `support`.
Eigen::MatrixX2d principal_curvatures(const KdTree3& tree, const Points& support, const Points& support_normals,
                                      const Points& query, const Points& query_normals, double radius);
/// crease_shape_index with `tree` built over support.points.
Eigen::VectorXd crease_shape_index(const KdTree3& tree, const Samples& support, const Samples& query, double radius);

}  // namespace fe
