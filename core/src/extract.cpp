// The pipeline of Takashima & Kanai, section 3: describe() (description.cpp) is steps 1-3, match()
// steps 4-6, each stage in its own file: pairing.h (step 4), clusters and placement votes
// (pairing.h), RANSAC (ransac.cpp) and one-pair placements (placements.h) for hypotheses,
// hypothesis.h to score and judge them, refine.h to refine them on the surface (with symmetry.h),
// coverage.h for what an accepted one covers, merge.h for each instance once. Then the search around
// match(): cut faces, the mirror image, the ridge-and-rut fallback, the time limit.
#include "featureextract/extract.h"

#include "coverage.h"
#include "description.h"
#include "featureextract/geometry.h"
#include "featureextract/reference.h"
#include "hypothesis.h"
#include "kdtree.h"
#include "merge.h"
#include "pairing.h"
#include "placements.h"
#include "refine.h"
#include "region_fit.h"
#include "topology.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <future>
#include <iterator>
#include <mutex>
#include <sstream>

namespace fe {

namespace {
// Topology fits whose costs differ by less than this (x L) are equally good (topology.h).
constexpr double kTopologyTie = 0.005;

// The region of a reference dense sample (-1: none).
int region_of_sample(const RegionGraph& g, const ShapeDescription::Impl& R, std::size_t i) {
  const int t = R.dense.triangle_ids(static_cast<Eigen::Index>(i));
  return t >= 0 && static_cast<std::size_t>(t) < g.triangle_region.size() ? g.triangle_region[static_cast<std::size_t>(t)] : -1;
}

// "target regions 3,7,12" for the debug trace
std::string topology_name(const TopologyHypothesis& h) {
  std::string n = "regions";
  for (std::size_t i = 0; i < h.image.size(); ++i) n += (i ? "," : " ") + std::to_string(h.image[i]);
  return n;
}
}  // namespace

Result match_core(const ShapeDescription& refd, const ShapeDescription& tgtd, const TriangleMesh& tmesh, const Params& p,
                  const ProgressFn& progress, const FeatureCore& core);

Result match(const ShapeDescription& refd, const ShapeDescription& tgtd, const TriangleMesh& tmesh, const Params& p,
             const ProgressFn& progress) {
  return match_core(refd, tgtd, tmesh, p, progress, FeatureCore{});
}

Result match_core(const ShapeDescription& refd, const ShapeDescription& tgtd, const TriangleMesh& tmesh, const Params& p,
                  const ProgressFn& progress, const FeatureCore& core) {
  if (refd.empty() || tgtd.empty()) throw std::invalid_argument("match: empty description");
  const auto& R = refd.impl();
  const auto& T = tgtd.impl();
  if (R.role != ShapeDescription::Role::Reference || T.role != ShapeDescription::Role::Target)
    throw std::invalid_argument("match: descriptions have the wrong roles");
  if (std::abs(R.L - T.L) > 1e-9 * R.L || R.m != T.m)
    throw std::invalid_argument("match: the target was described for another feature size or SHOT radii; describe it again");
  {
    const auto a = descriptor_parameters(R.params), b = descriptor_parameters(T.params);
    for (std::size_t i = 0; i < a.size(); ++i)
      if (a[i].second != b[i].second)
        throw std::invalid_argument(std::string("match: reference and target were described with another ") + a[i].first +
                                    "; describe them with the same parameters");
  }
  p.validate();
  set_threads(p);
  const double L = R.L;
  Stopwatch sw;
  Result res;
  res.params = p;
  res.feature_size = L;
  res.reference = R.stats;
  res.target = T.stats;
  res.timings = R.timings;
  res.timings.insert(res.timings.end(), T.timings.begin(), T.timings.end());
  res.warnings = R.warnings;
  res.warnings.insert(res.warnings.end(), T.warnings.begin(), T.warnings.end());

  // Step 4: C_SHOT, C_SI, C_SS.
  report(progress, "pairs", 0);
  const std::vector<KeyPointPair> cshot = shot_pairs(R.shot, T.shot, R.m, T.D, T.U, p.shot_neighbours,
                                                     [&](double f) { return !progress || progress("pairs", 0.9 * f); });
  const auto csi = si_pairs(R.key_si, T.key_si, p.si_neighbours);
  const std::vector<KeyPointPair> css = filter_by_shape_index(cshot, R.keys, T.keys, csi, p.pair_distance * L,
                                                              p.pair_distance * L, p.shot_radius_ratio);
  res.pairs_shot = cshot.size();
  res.pairs_ss = css.size();
  res.timings.push_back({"pairs", sw.lap()});

  // Step 5: Euclidean clusters of the paired target key points.
  report(progress, "clusters", 0);
  std::vector<int> tkeys;
  for (const auto& c : css) tkeys.push_back(c.tgt);
  std::sort(tkeys.begin(), tkeys.end());
  tkeys.erase(std::unique(tkeys.begin(), tkeys.end()), tkeys.end());
  Points tk(static_cast<Eigen::Index>(tkeys.size()), 3);
  for (std::size_t i = 0; i < tkeys.size(); ++i) tk.row(static_cast<Eigen::Index>(i)) = T.keys.row(tkeys[i]);
  const auto groups = euclidean_clusters(tk, p.cluster_tolerance * L);
  std::vector<int> cluster_of(static_cast<std::size_t>(T.keys.rows()), -1);
  for (std::size_t g = 0; g < groups.size(); ++g)
    for (int i : groups[g]) cluster_of[static_cast<std::size_t>(tkeys[static_cast<std::size_t>(i)])] = static_cast<int>(g);
  std::vector<std::vector<KeyPointPair>> cluster_pairs(groups.size());
  for (const auto& c : css) cluster_pairs[static_cast<std::size_t>(cluster_of[static_cast<std::size_t>(c.tgt)])].push_back(c);
  const PairFrames frames{R.shot, T.shot, R.m / 2, T.D};
  // Step 5b (issue 9): on a real part, fillets join every paired key point into one cluster. Each
  // pair's local frames and scale predict where the reference's center lands (a placement vote); the
  // votes split each cluster into one group per instance, and RANSAC runs on each group.
  if (p.vote_reach > 0) {
    const Eigen::Vector3d rc = 0.5 * (R.box_min + R.box_max);
    std::vector<std::vector<KeyPointPair>> split;
    for (const auto& cp : cluster_pairs) {
      Points votes(static_cast<Eigen::Index>(cp.size()), 3);
      std::vector<double> sc(cp.size());
      for (std::size_t i = 0; i < cp.size(); ++i) {
        const Eigen::Matrix3d rot = frames.rotation(cp[i]);
        sc[i] = std::pow(p.shot_radius_ratio, cp[i].shift);
        votes.row(static_cast<Eigen::Index>(i)) =
            (T.keys.row(cp[i].tgt).transpose() + sc[i] * rot * (rc - R.keys.row(cp[i].ref).transpose())).transpose();
      }
      for (const auto& g : vote_groups(votes, sc, 0.4 * p.vote_reach * L, p.vote_reach * L, p.min_cluster_pairs)) {
        split.emplace_back();
        for (int i : g) split.back().push_back(cp[static_cast<std::size_t>(i)]);
      }
    }
    cluster_pairs.swap(split);
  }
  std::vector<std::size_t> order;
  for (std::size_t g = 0; g < cluster_pairs.size(); ++g)
    if (static_cast<int>(cluster_pairs[g].size()) >= p.min_cluster_pairs) order.push_back(g);
  std::stable_sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return cluster_pairs[a].size() > cluster_pairs[b].size(); });
  res.clusters = order.size();
  res.timings.push_back({"clusters", sw.lap()});

  // Step 6: RANSAC per cluster, repeated to take every instance a cluster holds; each hypothesis
  // refined on the surface and judged on the feature's core.
  const HypothesisScorer scorer(R, T, p, core);
  const SurfaceRefinement refinement(R, T, p, scorer);
  if (refinement.symmetry().axisymmetric) {
    res.symmetry = "axisymmetric";
    res.symmetry_point = refinement.symmetry().point;
    res.symmetry_axis = refinement.symmetry().axis;
  }
  const std::function<double(const Eigen::Matrix4d&, double)> cost = [&scorer](const Eigen::Matrix4d& H, double limit) {
    return scorer.cost(H, limit);
  };
  const bool debug = std::getenv("FE_DEBUG") != nullptr;  // trace of every RANSAC outcome on stderr
  std::vector<Instance> found;
  // An accepted hypothesis becomes an instance with the target region it covers.
  auto add_instance = [&](const Eigen::Matrix4d& H, double s, const Evidence& ev, const KdTree3& mtree, double rms_unrefined, int pairs_explained) {
    const Deformation& df = ev.deformation;
    Instance inst;
    Match& mt = inst.match;
    mt.transform = H;
    mt.score = ev.score;
    mt.max_error = ev.error * s;
    mt.rms_error = ev.rms;
    mt.rms_error_unrefined = rms_unrefined;
    mt.scale = s;
    mt.pairs = pairs_explained;
    mt.key_agreement = ev.key_agreement;
    mt.stretch_min = df.scale_min;
    mt.stretch_max = df.scale_max;
    mt.perspective = df.perspective;
    mt.obstructed = ev.obstructed;
    mt.overhang = ev.overhang;
    // The instance's faces: the target within the tolerance of the mapped reference. What tells it
    // from another instance (merge.h): the target within the fit's error (twice its quantile error,
    // at most the tolerance) and a sample spacing, so that an exact fit of a passage does not reach
    // across the 0.8 mm of material to the passage above it.
    const double reach = ev.tolerance + R.dense_h * s;
    const double merge_reach = std::min(ev.tolerance, 2 * ev.error * s + 0.5 * R.dense_h * s) + R.dense_h * s;
    if (cover_target(ev.mapped, mtree, reach, merge_reach, T, tmesh, p.face_coverage, inst)) found.push_back(std::move(inst));
  };
  std::uint64_t run = 0, retry_run = 0;
  for (std::size_t oi = 0; oi < order.size(); ++oi) {
    std::vector<KeyPointPair> pairs = cluster_pairs[order[oi]];
    int failures = 0;
    int far_failures = 0;  // rejections in a row whose error is at its cap, before the cluster's first instance (max_far_failures)
    bool cluster_found = false;
    int retries_missed = 0;  // unguided retries in a row that found nothing
    // progress: clusters done, and within this one the share of its pairs explained or dropped
    const double initial_pairs = static_cast<double>(std::max<std::size_t>(1, pairs.size()));
    auto ransac_fraction = [&] {
      return (static_cast<double>(oi) + 1.0 - static_cast<double>(pairs.size()) / initial_pairs) / static_cast<double>(order.size());
    };
    // One hypothesis from a set of pairs: RANSAC, its samples guided by the pairs' local frames or
    // not, and (guided) the best one-pair placement beside it; the better one refined and judged.
    struct Attempt {
      bool any = false;  // a transform within bounds was found
      int iterations = 0;
      Polished chosen;
      Evidence ev;
      std::vector<Eigen::Vector3d> sample_targets;  // target points of the pairs it came from
    };
    auto attempt = [&](const std::vector<KeyPointPair>& ps, bool guided) {
      Attempt a;
      ++res.ransac_searches;
      Points rp(static_cast<Eigen::Index>(ps.size()), 3), tp(static_cast<Eigen::Index>(ps.size()), 3);
      for (std::size_t i = 0; i < ps.size(); ++i) {
        rp.row(static_cast<Eigen::Index>(i)) = R.keys.row(ps[i].ref);
        tp.row(static_cast<Eigen::Index>(i)) = T.keys.row(ps[i].tgt);
      }
      // Rotation (guided samples only) and scale of each pair from its SHOT local frames and radius shift.
      std::vector<Eigen::Matrix3d> rots;
      if (guided) {
        rots.resize(ps.size());
        for (std::size_t i = 0; i < ps.size(); ++i) rots[i] = frames.rotation(ps[i]);
      }
      std::vector<double> scales(ps.size());
      for (std::size_t i = 0; i < ps.size(); ++i) scales[i] = std::pow(p.shot_radius_ratio, ps[i].shift);
      RansacOptions ro;
      if (guided) ro.rotations = &rots;
      ro.scales = &scales;
      ro.max_iterations = p.ransac_max_iterations;
      ro.patience = p.ransac_patience;
      ro.locality = 1.5 * L;  // times the first pair's scale estimate
      ro.ratio_min = 0.8 * p.axis_scale_min;  // slack for key points that sit a sample spacing off
      ro.ratio_max = 1.25 * p.axis_scale_max;
      // the retries draw from a stream of their own, so the guided searches draw what they drew
      // without them
      ro.seed = guided ? p.seed * 1000003ULL + (++run) : p.seed * 1000003ULL + 500000ULL + (++retry_run);
      ro.batch = 16;  // scored on both cores, the same result as one at a time
      // The best one-pair placement competes with the RANSAC result below.
      Stopwatch at;  // (for the trace)
      const Placement placement = guided && p.pose_hypotheses ? one_pair_placement(ps, rp, tp, scales, frames, scorer) : Placement{};
      // RANSAC on its own (the one-pair placements must not cut its search short)
      RansacResult rr = ransac_projective(rp, tp, cost, ro, [&] { return progress && !progress("ransac", ransac_fraction()); });
      if (progress && !progress("ransac", ransac_fraction())) throw Cancelled();
      const double t_search = at.lap();
      a.iterations = rr.iterations;
      if (!rr.found && placement.pair < 0) return a;
      // Each candidate (RANSAC's, the best one-pair placement) is refitted and refined; the better
      // refined one is judged. A placement from one pair can settle on a part of the feature that the
      // refinement cannot extend, RANSAC's fit on a worse local optimum: neither is always right.
      // The two are independent: polished side by side when there are two (each polish is mostly
      // serial: its spin search alone was a quarter of CTC-02's RANSAC stage).
      Polished chosen, alt;
      if (rr.found && placement.pair >= 0) {
        side_by_side([&] { chosen = refinement.polish(rr.H, rr.cost, rp, tp); },
                     [&] { alt = refinement.polish(placement.H, placement.cost, rp, tp); });
      } else if (rr.found) {
        chosen = refinement.polish(rr.H, rr.cost, rp, tp);
      } else {
        alt = refinement.polish(placement.H, placement.cost, rp, tp);
      }
      if (rr.found) chosen.sample = rr.sample;
      const double polished_rr = rr.found ? chosen.cost : INFINITY, t_polish = at.lap();
      bool placed = false;
      if (placement.pair >= 0) {
        alt.sample.fill(placement.pair);
        if (!rr.found || alt.cost < 0.75 * chosen.cost) chosen = alt, placed = true;  // RANSAC's fit unless clearly worse
      }
      a.any = true;
      a.chosen = chosen;
      for (const int si : chosen.sample) a.sample_targets.push_back(tp.row(si).transpose());
      a.ev = scorer.evaluate(chosen.H, chosen.s, debug);
      if (debug) {
        const Eigen::Vector3d& c0 = a.sample_targets[0];
        const Deformation& df = a.ev.deformation;
        std::fprintf(stderr, "debug: cluster %zu pairs %zu%s at (%.1f %.1f %.1f): err/L %.3f score %.2f keys %.2f vol %.2f stretch %.2f..%.2f persp %.2f obstructed %.2f partial %.2f overhang %.2f it %d -> %s%s\n",
                     order[oi], ps.size(), guided ? "" : " (unguided)", c0.x(), c0.y(), c0.z(), a.ev.error / L, a.ev.score, a.ev.key_agreement, df.volume_ratio, df.scale_min,
                     df.scale_max, df.perspective, a.ev.obstructed, a.ev.partial_faces, a.ev.overhang, rr.iterations, a.ev.accepted() ? "accepted" : "rejected by ",
                     a.ev.failed().c_str());
        // which candidate won, their costs before and after polish, and when RANSAC improved
        std::string traj;
        for (const auto& [i, c] : rr.improvements) traj += " " + std::to_string(i) + ":" + std::to_string(c / L).substr(0, 6);
        std::fprintf(stderr, "   cost/L: ransac %.4f polished %.4f, placement %.4f polished %.4f: %s; placement and ransac %.2f s, polish %.2f s; ransac best at%s\n",
                     rr.found ? rr.cost / L : -1.0, rr.found ? polished_rr / L : -1.0, placement.pair >= 0 ? placement.cost / L : -1.0,
                     placement.pair >= 0 ? alt.cost / L : -1.0, placed ? "placement's" : "ransac's", t_search, t_polish, traj.c_str());
        const Eigen::Vector3d rc = 0.5 * (scorer.key_box_min() + scorer.key_box_max());
        const Eigen::Matrix3d J = transform_jacobian(chosen.H, rc);
        const Eigen::Vector3d m = apply_transform(chosen.H, rc);
        std::fprintf(stderr, "   ref center -> (%.1f %.1f %.1f)  J = [%.2f %.2f %.2f; %.2f %.2f %.2f; %.2f %.2f %.2f]\n", m.x(), m.y(), m.z(),
                     J(0, 0), J(0, 1), J(0, 2), J(1, 0), J(1, 1), J(1, 2), J(2, 0), J(2, 1), J(2, 2));
      }
      return a;
    };
    while (static_cast<int>(pairs.size()) >= p.min_cluster_pairs && failures < p.max_failures &&
           (p.max_far_failures <= 0 || far_failures < p.max_far_failures) && found.size() < 500) {
      report(progress, "ransac", ransac_fraction());
      Attempt a = attempt(pairs, true);
      if (!a.any) {
        if (debug) std::fprintf(stderr, "debug: cluster %zu pairs %zu: no transform within bounds (%d iterations)\n", order[oi], pairs.size(), a.iterations);
        break;
      }
      // A rejected hypothesis is sought once more among the pairs around it, RANSAC's samples not
      // guided by the local frames: on an instance stretched unequally along its axes (2.2 x 2.4 x 1)
      // the SHOT frames turn (of the pairs that map right, 3 in 97 had a frame rotation within 20
      // degrees of the instance's), so guided samples rarely hold four of them. A retry costs a
      // guided search: after kRetryMisses in a row that found nothing (a real part's long tail of
      // rejections), the cluster is not retried again.
      constexpr int kRetryMisses = 3;
      if (!a.ev.accepted() && p.ransac_unguided_retry && retries_missed < kRetryMisses) {
        const double reach = 3.0 * L * std::max(1.0, a.chosen.s);
        std::vector<KeyPointPair> near;
        for (const KeyPointPair& pr : pairs)
          if ((T.keys.row(pr.tgt).transpose() - a.sample_targets[0]).norm() <= reach) near.push_back(pr);
        if (static_cast<int>(near.size()) >= p.min_cluster_pairs) {
          Attempt b = attempt(near, false);
          if (b.any && b.ev.accepted()) {
            a = std::move(b);
            retries_missed = 0;
          } else {
            ++retries_missed;
          }
        }
      }
      const Eigen::Matrix4d H = a.chosen.H;
      const double s = a.chosen.s;
      const Evidence& ev = a.ev;
      const bool accepted = ev.accepted();
      const double tol = ev.tolerance;
      // Pairs whose target point this hypothesis explains are removed either way; on rejection only
      // those around its sample, so the next search looks elsewhere.
      // An accepted hypothesis that explains no pair (the same instance found again, its pairs gone)
      // drops those around its sample too, so the search goes on elsewhere instead of ending.
      const KdTree3 mtree(ev.mapped);
      auto remaining = [&](bool explained_by_map) {  // the pairs left after dropping one way or the other
        const double reach = explained_by_map ? std::max(2 * tol, 2 * T.sparse_h) : 0.1 * L * s;
        std::vector<KeyPointPair> left;
        for (std::size_t i = 0; i < pairs.size(); ++i) {
          const Eigen::Vector3d y = T.keys.row(pairs[i].tgt).transpose();
          bool drop = false;
          if (explained_by_map) {
            double d2;
            mtree.nearest(y, &d2);
            drop = std::sqrt(d2) <= reach;
          } else {
            for (const Eigen::Vector3d& st : a.sample_targets) drop = drop || (y - st).norm() <= reach;
          }
          if (!drop) left.push_back(pairs[i]);
        }
        return left;
      };
      std::vector<KeyPointPair> rest = remaining(accepted);
      if (accepted && rest.size() == pairs.size()) rest = remaining(false);
      if (debug) std::fprintf(stderr, "   pairs %zu -> %zu\n", pairs.size(), rest.size());
      if (rest.size() == pairs.size()) break;  // no progress possible
      const std::size_t explained = pairs.size() - rest.size();
      pairs.swap(rest);
      if (!accepted) {
        ++failures;
        // At the cap, a tenth or more of the mapped reference lies twice the acceptance error off the
        // target or faces away from it: a fit of nothing shaped like the feature, not a near miss.
        // Counted until the cluster's first instance: on a real part the instances can be a few of
        // many pairs, and after the first one the search may wander before the next (FTC-10's
        // drilled holes: found after 7 such rejections in a row).
        far_failures = !cluster_found && ev.error >= scorer.normal_penalty() ? far_failures + 1 : 0;
        continue;
      }
      failures = 0;
      far_failures = 0;
      cluster_found = true;
      add_instance(H, s, ev, mtree, a.chosen.rms_unrefined, static_cast<int>(explained));
    }
    if (debug && p.max_far_failures > 0 && far_failures >= p.max_far_failures)
      std::fprintf(stderr, "debug: cluster %zu given up with %zu pairs left: %d fits in a row at the error's cap before any instance\n", order[oi], pairs.size(), far_failures);
  }
  res.timings.push_back({"ransac", sw.lap()});

  // Step 6b (issue 9): hypotheses from how the reference's faces meet, for the instances whose
  // proportions or plain faces the SHOT pairs miss (topology.h); judged like RANSAC's.
  if (p.topology_hypotheses && R.regions.size() >= 2 && T.regions.size() >= 2) {
    report(progress, "topology", 0);
    // The reference's regions, with the context where a box cut it (topology.h).
    RegionGraph rg = R.regions;
    if (core.set) {
      std::array<bool, 6> sides{};
      for (int a = 0; a < 3; ++a) {
        sides[static_cast<std::size_t>(2 * a)] = core.lo(a) > R.box_min(a);
        sides[static_cast<std::size_t>(2 * a + 1)] = core.hi(a) < R.box_max(a);
      }
      mark_cut(rg, R.box_min, R.box_max, sides, 2e-3 * L);
    }
    const TopologyMatch tm = topology_hypotheses(rg, T.regions);
    res.topology_matches = tm.matches;
    // Its hypotheses are judged on the faces matched (the feature), not on the context a box took
    // along (a piece of the slot over the passage), when that differs from the scorer's core.
    std::vector<char> in_match(rg.size(), 0);
    for (int r : tm.matched) in_match[static_cast<std::size_t>(r)] = rg.regions[static_cast<std::size_t>(r)].cut ? 2 : 1;
    auto mask = std::make_shared<std::vector<char>>(R.dense.size(), 0);
    bool everything = true;
    for (std::size_t i = 0; i < R.dense.size(); ++i) {
      const int r = region_of_sample(rg, R, i);
      (*mask)[i] = r >= 0 ? in_match[static_cast<std::size_t>(r)] : 0;
      everything = everything && (*mask)[i] == 1;
    }
    FeatureCore topology_core;
    topology_core.set = true;
    topology_core.dense_feature = mask;
    topology_core.open_border = core.open_border;
    topology_core.open_border_face = core.open_border_face;
    // A topology match has matched every face, so the stretch bounds are wider (topology_*).
    Params pt = p;
    pt.axis_scale_min = std::min(p.axis_scale_min, p.topology_axis_scale_min);
    pt.axis_scale_max = std::max(p.axis_scale_max, p.topology_axis_scale_max);
    pt.max_anisotropy = std::max(p.max_anisotropy, p.topology_max_anisotropy);
    pt.volume_ratio_min = std::min(p.volume_ratio_min, std::pow(pt.axis_scale_min, 3));
    pt.volume_ratio_max = std::max(p.volume_ratio_max, std::pow(pt.axis_scale_max, 3));
    // Key point agreement guards RANSAC's fits of five key points; here every face and corner was
    // matched, and stretched crease key points fall between the target's (a hexagonal pocket at
    // 0.3x: 0.38 of them agree, the pocket itself 0.50).
    pt.min_key_agreement = 0;
    const HypothesisScorer scorer(R, T, pt, everything ? core : topology_core);
    const SurfaceRefinement refinement(R, T, pt, scorer);
    const int groups = tm.hypotheses.empty() ? 0 : tm.hypotheses.back().group + 1;
    for (std::size_t i = 0; i < tm.hypotheses.size();) {
      // One group: the fits onto one set of target regions; the one the surface agrees with best.
      const int g = tm.hypotheses[i].group;
      report(progress, "topology", static_cast<double>(g) / static_cast<double>(groups));
      if (!tm.hypotheses[i].border_agrees) {
        if (debug) std::fprintf(stderr, "debug: topology %s: what lies beyond its faces differs from the best match's\n", topology_name(tm.hypotheses[i]).c_str());
        while (i < tm.hypotheses.size() && tm.hypotheses[i].group == g) ++i;
        continue;
      }
      // Of fits the surface agrees with about equally (a turned rectangle on a rectangle), the first:
      // proper and least stretched.
      std::vector<std::pair<double, double>> costs;  // (cost, scale) per fit of the group, inf out of bounds
      const std::size_t first = i;
      double low = INFINITY;
      for (; i < tm.hypotheses.size() && tm.hypotheses[i].group == g; ++i) {
        const TopologyHypothesis& h = tm.hypotheses[i];
        double s0 = 1;
        double c = INFINITY;
        if (scorer.bounds_ok(h.H, &s0)) {
          c = scorer.cost(h.H, low + kTopologyTie * L);
          if (debug) std::fprintf(stderr, "debug: topology %s: cost %.4f L\n", topology_name(h).c_str(), c / L);
        } else if (debug) {
          const Deformation df = deformation(h.H, scorer.key_box_min(), scorer.key_box_max());
          std::fprintf(stderr, "debug: topology %s: out of bounds (%s: vol %.2f stretch %.2f..%.2f)\n", topology_name(h).c_str(),
                       deformation_outside(df, pt), df.volume_ratio, df.scale_min, df.scale_max);
        }
        low = std::min(low, c);
        costs.emplace_back(c, s0);
      }
      const TopologyHypothesis* pick = nullptr;
      Polished chosen;
      for (std::size_t k = 0; k < costs.size() && !pick; ++k)
        if (costs[k].first <= low + kTopologyTie * L) {
          pick = &tm.hypotheses[first + k];
          chosen.H = pick->H;
          chosen.s = costs[k].second;
          chosen.cost = costs[k].first;
          chosen.rms_unrefined = pick->residual;
        }
      if (!pick || !(chosen.cost < scorer.normal_penalty())) continue;
      const Polished pol = refinement.polish(pick->H, chosen.cost, pick->ref_points, pick->tgt_points);
      if (pol.cost < chosen.cost) chosen = pol;
      const Evidence ev = scorer.evaluate(chosen.H, chosen.s, debug);
      if (debug) {
        const Deformation& df = ev.deformation;
        std::fprintf(stderr, "debug: topology %s residual %.4f L: err/L %.3f score %.2f keys %.2f vol %.2f stretch %.2f..%.2f obstructed %.2f partial %.2f -> %s%s\n",
                     topology_name(*pick).c_str(), pick->residual / L, ev.error / L, ev.score, ev.key_agreement, df.volume_ratio, df.scale_min,
                     df.scale_max, ev.obstructed, ev.partial_faces, ev.accepted() ? "accepted" : "rejected by ", ev.failed().c_str());
      }
      if (!ev.accepted()) continue;
      const KdTree3 mtree(ev.mapped);
      add_instance(chosen.H, chosen.s, ev, mtree, pick->residual, 0);
    }
    res.timings.push_back({"topology", sw.lap()});
  }

  // Step 6c (issue 9): a reference that is one smooth region (a bead, a fin, a boss picked as its
  // faces), mapped by its principal frame onto the target's regions of the same proportions
  // (region_fit.h); judged like RANSAC's.
  if (p.topology_hypotheses && R.regions.size() == 1 && !R.regions.regions[0].planar && T.regions.size() >= 1) {
    report(progress, "topology", 0);
    std::vector<std::vector<Eigen::Index>> rows(T.regions.size());
    for (std::size_t j = 0; j < T.dense.size(); ++j) {
      const int r = region_of_sample(T.regions, T, j);
      if (r >= 0) rows[static_cast<std::size_t>(r)].push_back(static_cast<Eigen::Index>(j));
    }
    std::vector<RegionShape> shapes(rows.size());
    for (std::size_t r = 0; r < rows.size(); ++r)
      if (!rows[r].empty()) shapes[r] = region_shape(T.dense.points, rows[r]);
    RegionFitOptions ro;
    ro.axis_scale_min = p.axis_scale_min;
    ro.axis_scale_max = p.axis_scale_max;
    ro.max_anisotropy = p.max_anisotropy;
    const RegionShape ref_shape = region_shape(R.dense.points, {});
    const std::vector<RegionHypotheses> rhs = region_hypotheses(ref_shape, shapes, ro);
    for (std::size_t k = 0; k < rhs.size(); ++k) {
      report(progress, "topology", static_cast<double>(k) / static_cast<double>(rhs.size()));
      Polished chosen;
      chosen.cost = INFINITY;
      for (const Eigen::Matrix4d& H : rhs[k].H) {
        double s0 = 1;
        if (!scorer.bounds_ok(H, &s0)) continue;
        const double c = scorer.cost(H, chosen.cost);
        if (c < chosen.cost) chosen.H = H, chosen.s = s0, chosen.cost = c;
      }
      // (refined only where the principal frames already lay it near the surface)
      if (!(chosen.cost < 0.5 * scorer.normal_penalty())) {
        if (debug) std::fprintf(stderr, "debug: region %d: best of %zu frame fits cost %.4f L, not refined\n", rhs[k].region, rhs[k].H.size(), chosen.cost / L);
        continue;
      }
      const Polished pol = refinement.polish(chosen.H, chosen.cost, Points(0, 3), Points(0, 3));
      if (pol.cost < chosen.cost) chosen = pol;
      const Evidence ev = scorer.evaluate(chosen.H, chosen.s, debug);
      if (debug) {
        const Deformation& df = ev.deformation;
        std::fprintf(stderr, "debug: region %d (dissimilarity %.2f): err/L %.3f score %.2f keys %.2f vol %.2f stretch %.2f..%.2f obstructed %.2f partial %.2f -> %s%s\n",
                     rhs[k].region, rhs[k].dissimilarity, ev.error / L, ev.score, ev.key_agreement, df.volume_ratio, df.scale_min, df.scale_max, ev.obstructed,
                     ev.partial_faces, ev.accepted() ? "accepted" : "rejected by ", ev.failed().c_str());
      }
      if (!ev.accepted()) continue;
      const KdTree3 mtree(ev.mapped);
      add_instance(chosen.H, chosen.s, ev, mtree, chosen.rms_unrefined, 0);
    }
    res.timings.push_back({"regions", sw.lap()});
  }

  // Each instance once: the better-scoring of two overlapping instances wins.
  report(progress, "result", 0);
  res.matches = merge_instances(std::move(found), p.max_overlap);
  res.timings.push_back({"result", sw.lap()});
  report(progress, "done", 1);
  return res;
}

namespace {
void check_sizes(const TriangleMesh& reference, const TriangleMesh& target, const Params& params) {
  const double L = reference.diagonal();
  const double Lt = target.diagonal();
  if (!(L > 0)) throw InputError((reference.source.empty() ? "reference" : reference.source) + ": reference has zero size");
  if (L * params.scale_min > Lt * 1.0001) {
    std::ostringstream e;
    e << (reference.source.empty() ? "reference" : reference.source) << ": reference (diagonal " << L
      << ") is larger than the target " << (target.source.empty() ? "" : target.source) << " (diagonal " << Lt
      << ") even at the smallest scale searched (scale_min " << params.scale_min << ")";
    throw InputError(e.str());
  }
}

// The paper's key points miss features made of cylinders and flats (a lug: its hole and outer arc
// are ruts and ridges; a drilled hole, a slot, a step). When they find nothing, or the reference has
// too few of them to be searched at all, the search is repeated once with ridge and rut key points
// (ridge_rut_fallback); the result says so, and its parameters are the ones that found it.
// A search with these parameters may fall back to ridge and rut key points (it has not already).
bool can_fall_back(const Params& p) { return p.ridge_rut_fallback > 0 && !(p.ridge_rut_spacing > 0); }

template <class Run>
Result with_fallback(const Params& params, Run run) {
  const bool can_fall_back = fe::can_fall_back(params);
  Result res;
  std::string why;
  try {
    res = run(params);
    if (!res.matches.empty() || !can_fall_back) return res;
    why = "nothing found with the paper's key points";
  } catch (const NoKeyPoints& e) {
    if (!can_fall_back) throw;
    why = "the reference has too few of the paper's key points (caps, cups, saddles), or they lie in one spot";
  }
  double first = 0;
  for (const auto& t : res.timings) first += t.second;
  Params again = params;
  again.ridge_rut_spacing = params.ridge_rut_fallback;
  Result second = run(again);
  std::ostringstream w;
  w << why << "; searched with ridge and rut key points too (ridge_rut_spacing " << again.ridge_rut_spacing << "): "
    << second.matches.size() << " instance(s)";
  second.warnings.insert(second.warnings.begin(), w.str());
  if (first > 0) second.timings.insert(second.timings.begin(), {"first_pass", first});
  second.ransac_searches += res.ransac_searches;
  return second;
}

// The parameters that change a shape's description (steps 1-3), with the feature size.
std::string description_key(double L, const Params& p) {
  std::ostringstream k;
  k.precision(17);
  k << L << ' ' << p.seed << ' ' << p.scale_min << ' ' << p.scale_max;
  for (const auto& f : descriptor_parameters(p)) k << ' ' << f.second;
  return k.str();
}

// The reference as searched: without its cut faces when it was cut out of a part (detect_cut_faces).
struct SearchedReference {
  TriangleMesh mesh;
  CutFaces cut;
  std::vector<int> own_faces;     ///< box faces kept as the part's own (cut_faces_on_target), 1-based (B-rep input)
  std::size_t own_triangles = 0;  ///< their triangles
};
// `own_found`: the box faces the reference's matches put on the target (own_faces_where_found), when
// the reference does not sit on it unmoved.
// `through`: a clipped region's planes that it passes through between (CutFaces::own_triangle) are
// left out too (the second search of such a region, search_within).
SearchedReference searched_reference(const TriangleMesh& reference, const TriangleMesh& target, const Params& p,
                                     const std::vector<char>* own_found, bool through) {
  SearchedReference r;
  if (p.detect_cut_faces) r.cut = detect_cut_faces(reference);
  // Box faces that are the part's own (the box reached past the part there) are left out of the
  // search like cut faces, but their sides are not cut: the faces that end on them are whole there
  // (judged like picked faces: the whole-faces check, the open border's overhang), and the 20 %
  // next to those sides is not context.
  std::vector<char> drop = r.cut.cut_triangle;
  if (r.cut.triangles > 0 && p.cut_faces_on_target) {
    const CutFaces all = r.cut;
    r.cut = without_own_faces(reference, all, own_found ? *own_found : cut_faces_on_target(reference, all, target, 0.01 * reference.diagonal()));
    r.own_triangles = all.triangles - r.cut.triangles;
    std::set_difference(all.faces.begin(), all.faces.end(), r.cut.faces.begin(), r.cut.faces.end(), std::back_inserter(r.own_faces));
  }
  // A clipped mesh region that passes through between two of its box's planes (a hole across a wall)
  // leaves those planes out the same way in its second search: they are the wall's own faces.
  if (through && !r.cut.closed && r.cut.own_triangles > 0 && r.cut.own_triangle.size() == drop.size()) {
    for (std::size_t t = 0; t < drop.size(); ++t) drop[t] = static_cast<char>(drop[t] | r.cut.own_triangle[t]);
    r.own_triangles = r.cut.own_triangles;
  }
  const bool any = std::any_of(drop.begin(), drop.end(), [](char c) { return c != 0; });
  r.mesh = any ? without_triangles(reference, drop) : reference;
  return r;
}

template <class TargetFor>
Result search_within(const TriangleMesh& reference_in, const TriangleMesh& target, const Params& params_in, const ProgressFn& progress,
                     TargetFor target_for, const std::vector<char>* own_found = nullptr, bool through = false);

// The box faces that a match of a box-cut reference puts on the target's surface (cut_faces_on_target
// with the reference placed by the match): the part's own faces, where the box reached past the part
// the reference was cut out of, seen on the instances when the reference was not cut out of this very
// part (rescaled, stretched, mirrored, or another part). Per reference triangle, 1 for such a face.
std::vector<char> own_faces_where_found(const TriangleMesh& reference, const CutFaces& cut, const TriangleMesh& target,
                                        const std::vector<Match>& matches) {
  std::vector<char> own(static_cast<std::size_t>(reference.triangles.rows()), 0);
  for (const Match& m : matches) {
    const TriangleMesh placed = placed_mesh(reference, m.transform);
    const std::vector<char> o = cut_faces_on_target(placed, cut, target, 0.01 * placed.diagonal());
    for (std::size_t t = 0; t < o.size(); ++t) own[t] = static_cast<char>(own[t] | o[t]);
  }
  return own;
}

// On a part with B-rep faces, a fit that covers no face for face_coverage of its area lies along an
// edge or across parts of large faces: it claims none of the part's faces, so it cannot be colored
// or carry a mesh, and it is not a feature's instance (issue 9, occt_cooker_corners: a 7 mm hob
// corner clipped with its context is nine tenths flat top, edge fillet and worktop, so fits along
// the plate's straight edges passed with only the corner's own tenth off; 18 of its 38 false
// matches over its 15 development runs covered no face; over all 420 development runs, dropping
// them takes the false matches 62 -> 41 and the instances found 1,539 -> 1,538). Dropped after
// every merge, so that no decision of the search sees it, with a warning that counts them.
void drop_faceless(Result& res, const TriangleMesh& target, const Params& p) {
  if (!target.from_brep()) return;
  const auto faceless = [](const Match& m) { return m.faces.empty(); };
  const auto n = std::count_if(res.matches.begin(), res.matches.end(), faceless);
  if (n == 0) return;
  res.matches.erase(std::remove_if(res.matches.begin(), res.matches.end(), faceless), res.matches.end());
  std::ostringstream w;
  w << (target.source.empty() ? std::string("target") : target.source) << ": " << n
    << " fit(s) dropped that cover no face of the part for face_coverage (" << p.face_coverage
    << ") of its area: along an edge or across parts of large faces, not a feature's faces";
  res.warnings.push_back(w.str());
}

// The whole search for one reference: cut faces, the reference and (unless it is its own mirror
// image) its mirror image matched against the target's description from
// `target_for(L, params, progress)`,
// with the ridge-and-rut fallback around both.
template <class TargetFor>
Result search(const TriangleMesh& reference_in, const TriangleMesh& target, const Params& params_in, const ProgressFn& progress,
              TargetFor target_for) {
  params_in.validate();
  // Params::time_limit: every progress report checks the clock, and a run past it stops there (the
  // stages report often enough: per SHOT radius, per pair chunk, per RANSAC iteration batch).
  const auto start = std::chrono::steady_clock::now();
  bool out_of_time = false;
  const ProgressFn checked = params_in.time_limit <= 0 ? progress : ProgressFn([&](const std::string& stage, double f) {
    if (std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() > params_in.time_limit) {
      out_of_time = true;
      return false;
    }
    return !progress || progress(stage, f);
  });
  try {
    Result res = search_within(reference_in, target, params_in, checked, target_for);
    drop_faceless(res, target, params_in);
    return res;
  } catch (const Cancelled&) {
    if (!out_of_time) throw;
    std::ostringstream m;
    m << (target.source.empty() ? std::string("target") : target.source) << ": stopped after the time limit of "
      << params_in.time_limit << " s (time_limit)";
    throw TimeLimitExceeded(m.str());
  }
}

void band_skipped(Result& out, const ScaleBand& band, const std::string& why) {
  std::ostringstream w;
  w.precision(3);
  w << "instances " << band.f * band.lo << "-" << band.f * band.hi << " times the reference were not searched: " << why;
  out.warnings.push_back(w.str());
}

template <class TargetFor>
Result search_within(const TriangleMesh& reference_in, const TriangleMesh& target, const Params& params_in, const ProgressFn& progress,
                     TargetFor target_for, const std::vector<char>* own_found, bool through) {
  const SearchedReference sr = searched_reference(reference_in, target, params_in, own_found, through);
  const TriangleMesh& reference = sr.mesh;
  check_sizes(reference, target, params_in);
  FeatureCore fc = feature_core(reference_in, sr.cut);
  // The second search of a clipped region through a wall: it is the same reference, of the same size
  // (the target's description is the first search's), judged where it met the wall's faces.
  const double size_ratio = through && reference.diagonal() > 0 ? reference_in.diagonal() / reference.diagonal() : 1.0;
  if (through && sr.own_triangles > 0 && !sr.cut.closed) {
    Points outward;
    Points rims = through_rims(reference_in, sr.cut, &outward);
    if (rims.rows() > 0) {
      fc.through_ends = std::make_shared<const Points>(std::move(rims));
      fc.through_outward = std::make_shared<const Points>(std::move(outward));
    }
  }
  if (params_in.max_overhang > 0) {
    std::vector<int> bface;
    Points border = open_border_points(reference, 0.005 * reference.diagonal(), &bface);
    if (border.rows() > 0) {
      fc.open_border = std::make_shared<const Points>(std::move(border));
      fc.open_border_face = std::make_shared<const std::vector<int>>(std::move(bface));
    }
  }
  // One pass: the reference (scaled by a scale band's f, merge.h) and its mirror image.
  auto pass = [&](const TriangleMesh& ref, const FeatureCore& core, const Params& asked) {
    // With a size ladder, L is rounded to the ladder's nearest size: features of nearby sizes then ask
    // for the same target description (PreparedTarget, the library search), each described and judged
    // at that size (at most 2^(1/6), 12 %, off its own with 3 steps per doubling).
    const double L = size_on_ladder(ref.diagonal() * size_ratio, asked.size_ladder);
    // A part too large for the dense spacing (max_dense_points) is sampled coarser, and the reference is
    // then described with the same coarser spacings and radii: sampling only the target coarser left
    // its normals a sample or two each and its descriptors unlike the reference's (development case
    // ftc10_drilled_holes with the cap lowered to give 3.7x: 0 of 8 found, 6 of 8 with both coarser).
    const std::string tname = target.source.empty() ? std::string("target") : target.source;
    const double f = dense_coarsening(target, L, asked, tname);
    const Params params = coarsened(asked, f);
    auto describe_reference = [&](const TriangleMesh& m, const Params& with, const ProgressFn& told) {
      try {
        return describe(m, ShapeDescription::Role::Reference, L, with, told);
      } catch (const NoKeyPoints& e) {
        if (!(f > 1)) throw;
        std::ostringstream w;
        w.precision(3);
        w << e.what() << " (described " << f << "x coarser than the defaults because " << tname
          << " is too large for the dense spacing of this feature: search a region of the part, or raise max_dense_points)";
        throw NoKeyPoints(w.str());
      }
    };
    auto finish = [&](Result out) {
      if (f > 1) {
        out.params = asked;  // the parameters asked for; the warning says what the coarser pass used
        std::ostringstream w;
        w.precision(3);
        w << tname << ": surface too large for the dense spacing at this feature size (more than max_dense_points samples): "
          << "the reference and the target were both described " << f << "x coarser (dense spacing " << params.dense_spacing * L
          << "), small features may be missed";
        out.warnings.push_back(w.str());
      }
      return out;
    };
    const ShapeDescription r = describe_reference(ref, params, progress);
    const std::shared_ptr<const ShapeDescription> t = target_for(L, params, progress);
    const auto& R = r.impl();
    const bool symmetric = params.mirror && is_mirror_symmetric(R.dense.points, R.dense_normals, 1.5 * R.dense_h);
    if (!params.mirror || symmetric) {
      Result out = match_core(r, *t, target, params, progress, core);
      out.reference_mirror_symmetric = symmetric;
      return finish(std::move(out));
    }
    Eigen::Matrix4d M;
    const Eigen::Vector3d c = 0.5 * (R.box_min + R.box_max);
    const TriangleMesh mirrored_ref = mirrored_mesh(ref, c, &M);
    FeatureCore fm = core;  // the mirror image's core: reflected through x = c.x()
    if (core.set) {
      fm.lo.x() = 2 * c.x() - core.hi.x();
      fm.hi.x() = 2 * c.x() - core.lo.x();
    }
    if (core.open_border) {
      Points b = *core.open_border;
      b.col(0) = (2 * c.x() - b.col(0).array()).matrix();
      fm.open_border = std::make_shared<const Points>(std::move(b));
    }
    if (core.through_ends) {
      Points b = *core.through_ends, u = *core.through_outward;
      b.col(0) = (2 * c.x() - b.col(0).array()).matrix();
      u.col(0) = -u.col(0);
      fm.through_ends = std::make_shared<const Points>(std::move(b));
      fm.through_outward = std::make_shared<const Points>(std::move(u));
    }
    // The reference and its mirror image are two searches of one target description that know
    // nothing of each other until merged. One search keeps 1.4-1.5 of 2 cores busy (RANSAC scores
    // a few hypotheses at a time), so with two or more threads they run side by side, each on its
    // share; each finds what it finds on any number of threads, so the merged result is the same
    // as one after the other. The mirror image's search runs on a thread of its own and reports to
    // no one: this thread passes its stages on (a Cancel or the time limit stops both). FE_DEBUG
    // keeps them one after the other, so that each attempt's trace stays in one piece.
    // (Not side_by_side(): its OpenMP sections leave each search one thread on any machine, and it
    // would call `progress` from a thread that is not the caller's.)
    const int budget = thread_budget(params);
    Result out, theirs_found;
    if (budget < 2 || std::getenv("FE_DEBUG")) {
      out = match_core(r, *t, target, params, progress, core);
      theirs_found = match_core(describe_reference(mirrored_ref, params, progress), *t, target, params, progress, fm);
    } else {
      Params own = params, theirs = params;
      theirs.threads = budget / 2;
      own.threads = budget - theirs.threads;
      std::atomic<bool> stop{false};
      std::mutex seen_mutex;
      std::pair<std::string, double> seen{"reference", 0.0};  // the mirror search's last report
      const ProgressFn quiet = [&](const std::string& stage, double fr) {
        std::lock_guard<std::mutex> lock(seen_mutex);
        seen = {stage, fr};
        return !stop.load();
      };
      std::future<Result> mirror = std::async(std::launch::async, [&] {
        return match_core(describe_reference(mirrored_ref, theirs, quiet), *t, target, theirs, quiet, fm);
      });
      try {
        out = match_core(r, *t, target, own, progress, core);
        while (mirror.wait_for(std::chrono::milliseconds(50)) != std::future_status::ready) {
          std::pair<std::string, double> now;
          {
            std::lock_guard<std::mutex> lock(seen_mutex);
            now = seen;
          }
          report(progress, now.first, now.second);  // throws Cancelled when asked to stop
        }
      } catch (...) {
        stop = true;
        mirror.wait();  // its own Cancelled, or whatever it threw, goes with it
        set_threads(params);
        throw;
      }
      set_threads(params);
      theirs_found = mirror.get();  // what it threw, as one after the other would have
      out.params.threads = params.threads;  // the search's, not this half's
    }
    merge_mirrored(out, std::move(theirs_found), M, params);
    out.reference_mirror_symmetric = false;
    out.mirror_searched = true;
    return finish(std::move(out));
  };
  // With scale bands, the ridge-and-rut fallback happens when no band found anything (a band of small
  // instances that finds one keeps the fallback from searching the reference's own band again).
  Result res = with_fallback(params_in, [&](const Params& params) {
    const std::vector<ScaleBand> bands = scale_bands(params.scale_min, params.scale_max);
    Params first = params;
    first.scale_min = bands[0].lo;
    first.scale_max = bands[0].hi;
    Result out = pass(reference, fc, first);
    const Eigen::Vector3d c = 0.5 * (reference.vertices.colwise().minCoeff() + reference.vertices.colwise().maxCoeff()).transpose();
    const double Lt = target.diagonal();
    // a band's pass: the reference and its feature core scaled by f about c (S); the band's matches
    // map them, H S the reference
    auto band_pass = [&](const ScaleBand& band) {
      TriangleMesh ref = reference;
      ref.vertices = ((reference.vertices.rowwise() - c.transpose()) * band.f).rowwise() + c.transpose();
      FeatureCore core = fc;
      if (fc.set) {
        core.lo = c + band.f * (fc.lo - c);
        core.hi = c + band.f * (fc.hi - c);
      }
      if (fc.open_border)
        core.open_border = std::make_shared<const Points>(((fc.open_border->rowwise() - c.transpose()) * band.f).rowwise() + c.transpose());
      if (fc.through_ends)
        core.through_ends = std::make_shared<const Points>(((fc.through_ends->rowwise() - c.transpose()) * band.f).rowwise() + c.transpose());
      Params bp = params;
      bp.scale_min = band.lo;
      bp.scale_max = band.hi;
      if (std::getenv("FE_DEBUG")) std::fprintf(stderr, "debug: scale band f %.3f: instances %.3f-%.3f times the reference\n", band.f, band.f * band.lo, band.f * band.hi);
      return pass(ref, core, bp);
    };
    double top = 0;  // the largest scale the bands search
    for (const ScaleBand& band : bands) top = std::max(top, band.f * band.hi);
    // a band whose smallest instance is larger than the part is not searched
    auto fits_in_part = [&](const ScaleBand& band) { return reference.diagonal() * band.f * band.lo <= Lt * 1.0001; };
    for (std::size_t b = 1; b < bands.size(); ++b) {
      const ScaleBand& band = bands[b];
      if (!fits_in_part(band)) continue;
      const Eigen::Matrix4d S = scaling_about(c, band.f);
      try {
        merge_scale_band(out, band_pass(band), S, params);
      } catch (const NoKeyPoints& e) {  // a band that cannot be searched leaves the others' instances
        band_skipped(out, band, e.what());
      } catch (const InputError& e) {  // the part too large for instances that small (describe())
        band_skipped(out, band, e.what());
      }
    }
    // A match near the top of the range may be a larger instance whose fit was squeezed into it (the
    // volume ratio and the SHOT radii stop there): iso_scale's 3x rib came out at 2.68, stretched
    // 2.4-3.0, score 0.97, and the FE mesh placed on it failed the quality goal. The band above is
    // searched for a better fit of it (merge_band_above).
    const double near_top = kNearTop * top;
    const ScaleBand above = band_above(top);
    if (std::any_of(out.matches.begin(), out.matches.end(), [&](const Match& m) { return m.scale >= near_top; }) && fits_in_part(above)) {
      const Eigen::Matrix4d S = scaling_about(c, above.f);
      try {
        merge_band_above(out, band_pass(above), S, params, top);
      } catch (const NoKeyPoints&) {  // nothing better: the first fits stay
      } catch (const InputError&) {
      }
    }
    out.params.scale_min = params.scale_min;  // the range asked for, not the first band's
    out.params.scale_max = params.scale_max;
    return out;
  });
  // A box-cut reference not cut out of this part: do its matches put some of its box faces on the
  // target's surface? Then those are the part's own faces (a corner step's block sides, where the box
  // reached past the block), and the search is run again with them kept like that: the faces ending
  // on them are whole there, and a floor and wall alone no longer fit every floor-wall corner.
  if ((own_found || sr.own_triangles == 0) && params_in.cut_faces_on_target && sr.cut.triangles > 0 && !res.matches.empty()) {
    std::vector<char> own = own_faces_where_found(reference_in, sr.cut, target, res.matches);
    if (std::any_of(own.begin(), own.end(), [](char c) { return c != 0; })) {
      if (own_found)
        for (std::size_t t = 0; t < own.size(); ++t) own[t] = static_cast<char>(own[t] | (*own_found)[t]);
      if (std::getenv("FE_DEBUG")) std::fprintf(stderr, "debug: box faces on the target where matches put them: searched again with them as the part's own\n");
      return search_within(reference_in, target, params_in, progress, target_for, &own);
    }
  }
  res.reference_closed = sr.cut.closed;
  res.reference_cut_faces = sr.cut.faces;
  res.reference_own_faces = sr.own_faces;
  res.reference_cut_triangles = sr.cut.triangles;
  static const char* const kSide[6] = {"-x", "+x", "-y", "+y", "-z", "+z"};
  std::string sides;
  for (std::size_t s = 0; s < 6; ++s)
    if (sr.cut.cut_sides[s]) {
      res.reference_cut_sides.emplace_back(kSide[s]);
      sides += (sides.empty() ? "" : ", ") + std::string(kSide[s]);
    }
  if (!sr.cut.closed && !sides.empty()) {
    std::ostringstream w;
    w << (reference_in.source.empty() ? "reference" : reference_in.source) << ": open mesh region whose border runs along its box's "
      << sides << " side(s), taken as clipped there: the 20 % next to them is judged as context";
    res.warnings.push_back(w.str());
  }
  if (sr.cut.triangles > 0) {
    std::ostringstream w;
    w << (reference_in.source.empty() ? "reference" : reference_in.source) << ": closed reference, searched without its "
      << (sr.cut.faces.empty() ? std::to_string(sr.cut.triangles) + " cut triangles" : std::to_string(sr.cut.faces.size()) + " cut face(s)")
      << " (planar faces on its bounding box where it was cut out; detect_cut_faces)";
    res.warnings.push_back(w.str());
  }
  if (sr.own_triangles > 0 && !sr.cut.closed) {
    std::ostringstream w;
    w << (reference_in.source.empty() ? "reference" : reference_in.source) << ": " << sr.own_triangles
      << " triangle(s) in two opposite planes of its box that the region passes through between (a wall's two faces, where the box reached past the part): "
      << "searched again without them, as the part's own faces that an instance may go on past (detect_cut_faces)";
    res.warnings.push_back(w.str());
  } else if (sr.own_triangles > 0) {
    std::ostringstream w;
    w << (reference_in.source.empty() ? "reference" : reference_in.source) << ": "
      << (reference_in.from_brep() ? std::to_string(sr.own_faces.size()) + " face(s)" : std::to_string(sr.own_triangles) + " triangle(s)") << " on its bounding box lie on "
      << (target.source.empty() ? std::string("the target") : target.source)
      << (own_found ? "'s surface where a first search's matches put the reference" : "'s surface where it was cut out of it")
      << ": the part's own faces, where the box reached past the part; left out like cut faces, but the faces ending on them are whole there (cut_faces_on_target)";
    res.warnings.push_back(w.str());
  }
  // A clipped region that passes through between two planes of its box (a hole across a wall whose box
  // reached past both of the wall's faces): those are the part's own faces, which an instance need
  // not have where the reference has them (a hole through a taller boss goes on past the wall's far
  // face). It is searched a second time without them, judged where it met them
  // (HypothesisScorer::through_share), and the instances of both searches join. The first search
  // keeps them: they hold a larger hole through the same wall to the wall's thickness. Only on a
  // target with B-rep faces: a mesh target has none to tell a face that goes on from one that ends.
  if (!through && !sr.cut.closed && sr.cut.own_triangles > 0 && target.from_brep()) {
    Result second = search_within(reference_in, target, params_in, progress, target_for, nullptr, true);
    for (std::string& w : second.warnings)
      if (std::find(res.warnings.begin(), res.warnings.end(), w) == res.warnings.end() && w.find("(detect_cut_faces)") == std::string::npos)
        w = "without the planes it passes through between: " + w;
    merge_through(res, std::move(second), params_in);
  }
  return res;
}
}  // namespace

namespace {
using Descriptions = std::vector<std::pair<std::string, std::shared_ptr<const ShapeDescription>>>;

// The target's description for one pass. The ridge-and-rut fallback's pass reuses the description
// of the first pass with the same size and parameters, if `made` still holds it (describe_reusing:
// the same description, without sampling, normals, shape index and the paper's key points' SHOT again).
std::shared_ptr<const ShapeDescription> describe_target(const TriangleMesh& target, double L, const Params& params,
                                                        const ProgressFn& progress, const Descriptions& made) {
  if (params.ridge_rut_spacing > 0) {
    Params first = params;
    first.ridge_rut_spacing = 0;
    const std::string key = description_key(L, first);
    for (const auto& m : made)
      if (m.first == key) return std::make_shared<const ShapeDescription>(describe_reusing(target, *m.second, params, progress));
  }
  return std::make_shared<const ShapeDescription>(describe(target, ShapeDescription::Role::Target, L, params, progress));
}
}  // namespace

double size_on_ladder(double L, int steps) {
  if (steps <= 0 || !(L > 0)) return L;
  return std::exp2(std::round(std::log2(L) * steps) / static_cast<double>(steps));
}

PreparedTarget::PreparedTarget(TriangleMesh mesh) : mesh_(std::move(mesh)) {}

Result PreparedTarget::extract(const TriangleMesh& reference, const Params& params_in, const ProgressFn& progress) {
  return search(reference, mesh_, params_in, progress, [&](double L, const Params& params, const ProgressFn& checked) {
    const std::string key = description_key(L, params);
    std::lock_guard<std::mutex> lock(mutex_);  // a second query for the same key waits instead of recomputing
    for (const auto& c : cache_)
      if (c.first == key) return c.second;
    auto t = describe_target(mesh_, L, params, checked, cache_);
    cache_.emplace_back(key, t);
    ++built_;
    if (cache_.size() > 4) cache_.erase(cache_.begin());  // bounded memory
    return t;
  });
}

Result extract(const TriangleMesh& reference, const TriangleMesh& target, const Params& params_in, const ProgressFn& progress) {
  // One description per pass. The first one (the reference's own scale band) is kept for the
  // ridge-and-rut fallback to reuse, and for a second search with the part's own faces found through
  // the matches (search_within), which asks for it again with the same key: one description more in
  // memory while a band, the fallback or the second search runs.
  Descriptions first;
  return search(reference, target, params_in, progress, [&](double L, const Params& params, const ProgressFn& checked) {
    const std::string key = description_key(L, params);
    for (const auto& m : first)
      if (m.first == key) return m.second;
    auto t = describe_target(target, L, params, checked, first);
    if (first.empty()) first.emplace_back(key, t);
    return t;
  });
}

}  // namespace fe
