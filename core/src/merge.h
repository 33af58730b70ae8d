// Internal: each instance once. Hypotheses of one search that cover the same target region are one
// instance (the better score wins), and so are a direct and a mirrored match of the same place.
#pragma once

#include "coverage.h"
#include "featureextract/result.h"

#include <Eigen/Core>
#include <vector>

namespace fe {

/// Stable order for the user: by position (x, then y, then z), then score (a strict weak order).
void sort_matches(std::vector<Match>& m);

/// Two matches list mostly the same target faces: they share more than half of the longer list
/// (false when either lists none).
bool same_faces(const Match& a, const Match& b);

/// Two instances lie mostly on the same target faces (Instance::touched): they share more than half
/// of the longer list (false when either lists none). NIST CTC-01: a 50 mm deep hole's fits over the
/// upper and the lower part of a 100 mm one each cover about 43 % of its wall, less than a face needs
/// to be listed, and little of each other's samples.
bool same_touched(const Instance& a, const Instance& b);

/// The instances of one search, each once: of two that share more than max_overlap of the smaller
/// one's covered samples, or mostly the same faces (same_faces: two fits of a smaller reference
/// sliding along one longer instance cover different samples of the same faces; or same_touched), the better-scoring
/// one stays (the earlier one on a tie). Sorted.
std::vector<Match> merge_instances(std::vector<Instance> found, double max_overlap);

/// Two matches are one instance when they share more than max_overlap of the smaller one's faces
/// (triangles for mesh input; boxes when neither is listed).
bool same_instance(const Match& a, const Match& b, double max_overlap);
/// How much two matches share: the Jaccard index of their faces (triangles for mesh input; of their
/// boxes' volumes when neither is listed).
double overlap_share(const Match& a, const Match& b);

/// Matches of the mirrored reference join the result: their H maps the original reference (H M),
/// and where a mirrored and a direct match are the same instance the better score wins (the direct
/// one unless the mirrored one scores 0.02 more, so that a symmetric feature is never reported as
/// mirrored). A joining match that is the same instance as several is that one it shares most with
/// (overlap_share). Counts and timings are added.
void merge_mirrored(Result& res, Result mirrored, const Eigen::Matrix4d& M, const Params& p);

/// Matches of a clipped region's second search, without the planes it passes through between
/// (search_within), join the result as merge_mirrored's do (same frame: H unchanged); one that lists
/// no target faces (a fit sliding along a longer hole than the first search's match of it) is the
/// same instance as any match whose box its box meets.
void merge_through(Result& res, Result through, const Params& p);

/// Scale bands. One pass of the search covers instances kBandScaleMin to kBandScaleMax times the
/// reference well (SHOT's radius ladder and the key points' curvature radius are set by the
/// reference's size): a range beyond that (scale_min 1/3, scale_max 3) is searched in bands, each a
/// pass with the reference scaled by f about its box center and scale_min, scale_max relative to it
/// (lo, hi), so that each pass works near the scales it is good at and describes the target at a
/// resolution fit for the instances it looks for. The first band is the reference itself.
constexpr double kBandScaleMin = 0.8, kBandScaleMax = 2.6;
struct ScaleBand {
  double f = 1, lo = kBandScaleMin, hi = kBandScaleMax;
};
/// The bands that tile [scale_min, scale_max]: one band {1, scale_min, scale_max} when the range fits
/// in one pass; else the band of the reference itself, bands below it (the reference shrunk, the
/// target described finer), then above it.
std::vector<ScaleBand> scale_bands(double scale_min, double scale_max);
/// The 4x4 scaling by f about `center`.
Eigen::Matrix4d scaling_about(const Eigen::Vector3d& center, double f);
/// Matches of a scale band's pass join the result as merge_mirrored does, their H composed with the
/// band's scaling S = scaling_about(center, f) (H S), their scale and stretches multiplied by f.
void merge_scale_band(Result& res, Result band, const Eigen::Matrix4d& S, const Params& p);
/// The band just above instances `top` times the reference (top to top x kBandScaleMax / kBandScaleMin).
ScaleBand band_above(double top);
/// Matches within kNearTop of the top of the range (scale kNearTop x top or more) may be instances
/// larger than the range searched, their fits squeezed into it (a rib 2.9x its reference fitted at
/// 2.49 with stretches 2.3-2.6): the band above is searched, and its match of such an instance
/// replaces the first one where it scores at least as well (0.005 less is noise). The band's other
/// matches lie beyond the range asked for: they are not added, a warning says how many there are.
constexpr double kNearTop = 0.95;
void merge_band_above(Result& res, Result band, const Eigen::Matrix4d& S, const Params& p, double top);

}  // namespace fe
