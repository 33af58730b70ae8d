// Internal: hypotheses for a reference that is one smooth region (issue 9). A bead, a fin or a boss
// picked as its faces is one region: its faces meet tangentially, so the topology stage (topology.h)
// has no contacts to match, and on a thin feature (Motor-c's beads: 6 mm wide on a half ring 70 mm
// across) every SHOT support reaches past the picked faces' border, so few key point pairs are right
// (5 % of the pairs there had their target point on a bead, 7 % of those placed it right). The
// target's regions (regions.h) are bounded by creases as the reference's faces are by their border:
// a target region of the same shape, its samples' principal extents in proportion within the stretch
// bounds, gives the affine maps that carry the reference region's principal axes and extents onto its
// own, one per choice of the axes' senses and order that keeps the handedness. They are judged like
// any other hypothesis (hypothesis.h).
#pragma once

#include "featureextract/mesh.h"

#include <Eigen/Core>
#include <cstddef>
#include <vector>

namespace fe {

/// The principal frame of a set of points: centroid, axes (columns, by decreasing extent) and the
/// standard deviation along each.
struct RegionShape {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d sigma = Eigen::Vector3d::Zero();
  std::size_t samples = 0;
};

/// The shape of rows `rows` of `x` (all rows when empty).
RegionShape region_shape(const Points& x, const std::vector<Eigen::Index>& rows);

struct RegionFitOptions {
  double axis_scale_min = 0.5;   ///< bounds of the extents' ratios, target over reference, per axis
  double axis_scale_max = 3.2;
  double max_anisotropy = 3.0;   ///< largest ratio over smallest
  std::size_t min_samples = 30;  ///< target regions with fewer samples are not tried
  std::size_t max_regions = 24;  ///< at most this many target regions, the most alike in proportion first
};

/// The candidate maps onto one target region.
struct RegionHypotheses {
  int region = -1;
  double dissimilarity = 0;  ///< spread of the per-axis log ratios (0: the same proportions)
  std::vector<Eigen::Matrix4d> H;  ///< affine, reference -> target, proper (determinant > 0)
};

/// For each target region (`targets`, indexed by region; regions with no samples have samples 0)
/// whose extents are in proportion with `ref`'s, the proper affine maps of `ref`'s principal frame
/// onto its own. Axes whose extents are within 15 % of each other are tried in either order (their
/// principal directions are not defined by the samples). Regions most alike first.
std::vector<RegionHypotheses> region_hypotheses(const RegionShape& ref, const std::vector<RegionShape>& targets,
                                                const RegionFitOptions& o = {});

}  // namespace fe
