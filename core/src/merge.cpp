// Each instance once (merge.h).
#include "merge.h"

#include <sstream>

#include <cstdio>
#include <cstdlib>

#include <algorithm>
#include <iterator>

namespace fe {

void sort_matches(std::vector<Match>& m) {
  std::sort(m.begin(), m.end(), [](const Match& a, const Match& b) {
    for (int i = 0; i < 3; ++i)
      if (a.center[i] != b.center[i]) return a.center[i] < b.center[i];
    return a.score > b.score;
  });
}

bool same_faces(const Match& a, const Match& b) {
  if (a.faces.empty() || b.faces.empty()) return false;
  std::vector<int> x = a.faces, y = b.faces, both;
  std::sort(x.begin(), x.end());
  std::sort(y.begin(), y.end());
  std::set_intersection(x.begin(), x.end(), y.begin(), y.end(), std::back_inserter(both));
  return 2 * both.size() > std::max(x.size(), y.size());
}

bool same_touched(const Instance& a, const Instance& b) {
  if (a.touched.empty() || b.touched.empty()) return false;
  std::vector<int> both;
  std::set_intersection(a.touched.begin(), a.touched.end(), b.touched.begin(), b.touched.end(), std::back_inserter(both));
  return 2 * both.size() > std::max(a.touched.size(), b.touched.size());
}

std::vector<Match> merge_instances(std::vector<Instance> found, double max_overlap) {
  std::stable_sort(found.begin(), found.end(), [](const Instance& a, const Instance& b) { return a.match.score > b.match.score; });
  std::vector<const Instance*> kept;
  for (const Instance& f : found) {
    bool dup = false;
    for (const Instance* k : kept) {
      std::vector<int> both;
      std::set_intersection(f.covered.begin(), f.covered.end(), k->covered.begin(), k->covered.end(), std::back_inserter(both));
      const double denom = static_cast<double>(std::min(f.covered.size(), k->covered.size()));
      dup = dup || static_cast<double>(both.size()) > max_overlap * denom || same_faces(f.match, k->match) || same_touched(f, *k);
    }
    if (std::getenv("FE_DEBUG"))
      std::fprintf(stderr, "debug: instance at (%.1f %.1f %.1f) score %.3f, %zu samples covered: %s\n", f.match.center.x(), f.match.center.y(),
                   f.match.center.z(), f.match.score, f.covered.size(), dup ? "merged into a better one" : "kept");
    if (!dup) kept.push_back(&f);
  }
  std::vector<Match> out;
  for (const Instance* k : kept) out.push_back(k->match);
  sort_matches(out);
  return out;
}

namespace {
// What two matches share, and how large each is: faces listed, else triangles (mesh input), else
// their boxes' volumes (each side grown by 1 % of both diagonals when `padded`, so that flat boxes
// still overlap). same_instance and overlap_share judge the same measure two ways.
struct Shared {
  double both = 0, a = 0, b = 0;
};
Shared shared(const Match& a, const Match& b, bool padded) {
  auto lists = [](std::vector<int> x, std::vector<int> y) {
    std::sort(x.begin(), x.end());
    std::sort(y.begin(), y.end());
    std::vector<int> both;
    std::set_intersection(x.begin(), x.end(), y.begin(), y.end(), std::back_inserter(both));
    return Shared{static_cast<double>(both.size()), static_cast<double>(x.size()), static_cast<double>(y.size())};
  };
  if (!a.faces.empty() && !b.faces.empty()) return lists(a.faces, b.faces);
  if (!a.triangles.empty() && !b.triangles.empty()) return lists(a.triangles, b.triangles);
  const double pad = padded ? 1e-9 + 0.01 * ((a.bbox_max - a.bbox_min).norm() + (b.bbox_max - b.bbox_min).norm()) : 0.0;
  auto vol = [&](const Eigen::Vector3d& l, const Eigen::Vector3d& h) {
    const Eigen::Array3d e = (h - l).array() + pad;
    return padded ? e.prod() : e.max(0.0).prod();
  };
  Shared out{0, vol(a.bbox_min, a.bbox_max), vol(b.bbox_min, b.bbox_max)};
  const Eigen::Vector3d lo = a.bbox_min.cwiseMax(b.bbox_min), hi = a.bbox_max.cwiseMin(b.bbox_max);
  if (!(lo.array() > hi.array()).any()) out.both = vol(lo, hi);
  return out;
}
}  // namespace

bool same_instance(const Match& a, const Match& b, double max_overlap) {
  const Shared s = shared(a, b, true);
  return s.both > 0 && s.both > max_overlap * std::min(s.a, s.b);
}

double overlap_share(const Match& a, const Match& b) {
  const Shared s = shared(a, b, false);
  const double all = s.a + s.b - s.both;
  return all > 0 ? s.both / all : 0.0;
}

namespace {
// Matches of another search of the same reference join `res`: their H maps that search's reference,
// which is M applied to this one's (H M); where two are the same instance the first stays unless the
// other scores 0.02 more. Counts and timings are added, the timings under `prefix`.
// `faceless_overlap`: a joining match that lists no faces (a fit that covers no target face enough,
// as one sliding along a longer instance does) is the same instance as any match whose box its box
// meets.
// `replace_from` > 0: a joining match only replaces a match of scale replace_from or more that is
// the same instance, where it scores at least as well (within 0.005); it is never added. Returns
// how many joining matches were the same instance as none.
int join(Result& res, Result other, const Eigen::Matrix4d& M, bool mirrored, double scale, const std::string& prefix, const Params& p,
         bool faceless_overlap = false, double replace_from = 0) {
  int alone = 0;
  for (Match& m : other.matches) {
    m.transform = m.transform * M;
    m.transform /= m.transform(3, 3);
    m.scale *= scale;
    m.stretch_min *= scale;  // singular values of H's Jacobian: H S's are f times H's
    m.stretch_max *= scale;
    m.mirrored = m.mirrored || mirrored;
    // The instance m is: of the matches it is the same instance as, the one it shares most with. (It
    // was the first in center order: on FTC-10 a small drilled hole's mirrored match, which shares one
    // tiny cone face with a large hole's match, replaced the large hole and duplicated itself.)
    Match* same = nullptr;
    double most = -1;
    for (Match& d : res.matches) {
      const bool meets = faceless_overlap && m.faces.empty() && !d.faces.empty() && (m.bbox_min.array() <= d.bbox_max.array()).all() &&
                         (d.bbox_min.array() <= m.bbox_max.array()).all();
      if (!meets && !same_instance(m, d, p.max_overlap)) continue;
      const double share = overlap_share(m, d);
      if (share > most) {
        most = share;
        same = &d;
      }
    }
    alone += same ? 0 : 1;
    if (replace_from > 0) {
      if (same && same->scale >= replace_from && m.score >= same->score - 0.005) *same = m;
    } else if (!same) {
      res.matches.push_back(m);
    } else if (m.score > same->score + 0.02) {
      *same = m;
    }
  }
  sort_matches(res.matches);
  res.pairs_shot += other.pairs_shot;
  res.pairs_ss += other.pairs_ss;
  res.clusters += other.clusters;
  res.topology_matches += other.topology_matches;
  res.ransac_searches += other.ransac_searches;
  for (const auto& t : other.timings)
    if (!mirrored || t.first.rfind("target_", 0) != 0) res.timings.push_back({prefix + t.first, t.second});
  if (!mirrored)  // a band's own description of the part (sampled coarser than asked, ...)
    for (const std::string& w : other.warnings)
      if (std::find(res.warnings.begin(), res.warnings.end(), w) == res.warnings.end()) res.warnings.push_back(w);
  return alone;
}
}  // namespace

void merge_mirrored(Result& res, Result mirrored, const Eigen::Matrix4d& M, const Params& p) {
  join(res, std::move(mirrored), M, true, 1.0, "mirror_", p);
}

void merge_through(Result& res, Result through, const Params& p) {
  join(res, std::move(through), Eigen::Matrix4d::Identity(), false, 1.0, "through_", p, true);
}

void merge_scale_band(Result& res, Result band, const Eigen::Matrix4d& S, const Params& p) {
  const double f = S(0, 0);
  std::ostringstream prefix;
  prefix << "scale_band_" << f << "_";
  join(res, std::move(band), S, false, f, prefix.str(), p);
}

void merge_band_above(Result& res, Result band, const Eigen::Matrix4d& S, const Params& p, double top) {
  const double f = S(0, 0);
  std::ostringstream prefix;
  prefix << "band_above_" << f << "_";
  const int beyond = join(res, std::move(band), S, false, f, prefix.str(), p, false, kNearTop * top);
  if (beyond > 0) {
    std::ostringstream w;
    w.precision(3);
    w << beyond << " more instance(s) larger than scale_max (" << top << ") were found in the band above it, searched for a better fit of "
      << "a match near that limit: not reported; search with a larger scale_max (the Wide scale preset: 3) to report them";
    res.warnings.push_back(w.str());
  }
}

Eigen::Matrix4d scaling_about(const Eigen::Vector3d& center, double f) {
  Eigen::Matrix4d S = Eigen::Matrix4d::Identity();
  S.topLeftCorner<3, 3>() *= f;
  S.topRightCorner<3, 1>() = (1.0 - f) * center;
  return S;
}

namespace {
// The band for instances a to b times the reference (b / a <= kBandScaleMax / kBandScaleMin): the
// reference scaled so that a is kBandScaleMin times it; for a narrow band, so that a is 1 (the
// relative range stays within the parameters' bounds, scale_min <= 1 <= scale_max).
ScaleBand band_for(double a, double b) {
  if (b / a >= 1.0 / kBandScaleMin) {
    const double f = a / kBandScaleMin;
    return {f, kBandScaleMin, b / f};
  }
  return {a, 1.0, b / a};
}
}  // namespace

ScaleBand band_above(double top) { return band_for(top, top * kBandScaleMax / kBandScaleMin); }

std::vector<ScaleBand> scale_bands(double scale_min, double scale_max) {
  if (scale_min >= kBandScaleMin * (1 - 1e-9) && scale_max <= kBandScaleMax * (1 + 1e-9)) return {{1.0, scale_min, scale_max}};
  const double ratio = kBandScaleMax / kBandScaleMin;
  std::vector<ScaleBand> out{{1.0, std::max(scale_min, kBandScaleMin), std::min(scale_max, kBandScaleMax)}};
  // Below: each band as coarse as it can be, ending where the one above starts; then above.
  for (double lo = out[0].lo; lo > scale_min * (1 + 1e-9);) {
    const double a = std::max(scale_min, lo / ratio);
    out.push_back(band_for(a, lo));
    lo = a;
  }
  for (double hi = out[0].hi; hi < scale_max * (1 - 1e-9);) {
    const double b = std::min(scale_max, hi * ratio);
    out.push_back(band_for(hi, b));
    hi = b;
  }
  return out;
}

}  // namespace fe
