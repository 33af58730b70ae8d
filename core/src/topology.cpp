// Hypotheses from how the reference's regions meet (topology.h).
#include "topology.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <numeric>
#include <tuple>

namespace fe {

bool fit_affine(const Points& a, const Points& b, Eigen::Matrix4d* H, double* rms) {
  const Eigen::Index n = a.rows();
  if (n < 4 || b.rows() != n) return false;
  const Eigen::RowVector3d ca = a.colwise().mean(), cb = b.colwise().mean();
  const Eigen::MatrixXd A = a.rowwise() - ca, B = b.rowwise() - cb;
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const Eigen::Vector3d sv = svd.singularValues();
  if (!(sv(0) > 0) || sv(2) < 1e-3 * sv(0)) return false;
  // B = A M, M = A^+ B (3 x 3); y = M^T (x - ca) + cb
  const Eigen::Matrix3d M = svd.solve(B);
  H->setIdentity();
  H->topLeftCorner<3, 3>() = M.transpose();
  H->topRightCorner<3, 1>() = cb.transpose() - M.transpose() * ca.transpose();
  if (rms) *rms = std::sqrt((A * M - B).rowwise().squaredNorm().mean());
  return true;
}

namespace {

constexpr int kOut = -1;                          // label of what lies outside the match
constexpr double kSharp = 30.0 * M_PI / 180.0;    // contacts at least this sharp tell convex from concave beyond a match
constexpr std::size_t kMaxTies = 32;              // equally good fits kept per set of target regions
constexpr double kTangent = 15.0 * M_PI / 180.0;  // contacts this flat have no reliable sense

bool contacts_agree(const RegionGraph::Contact& a, const RegionGraph::Contact& b, double tol) {
  if (std::abs(a.angle) < kTangent && std::abs(b.angle) < kTangent) return true;
  if ((a.angle > 0) != (b.angle > 0)) return false;
  return std::abs(a.angle - b.angle) <= tol;
}

struct Corner {
  std::vector<int> key;  // sorted labels: positions in the match order, kOut
  Eigen::Vector3d point;
};

// Corners of the matched regions on one side. `pos` maps a region to its position in the match
// order or kOut. A corner: where three or more labels meet, or where a matched region's border turns.
template <class Pos>
std::vector<Corner> corners(const RegionGraph& g, const std::vector<int>& region_set, Pos pos, bool skip_cut) {
  std::vector<int> verts;
  for (int r : region_set) verts.insert(verts.end(), g.regions[static_cast<std::size_t>(r)].border.begin(), g.regions[static_cast<std::size_t>(r)].border.end());
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  std::vector<Corner> out;
  for (int v : verts) {
    const auto& vx = g.vertices[static_cast<std::size_t>(v)];
    if (skip_cut && vx.on_cut) continue;
    Corner c;
    for (int r : vx.regions) c.key.push_back(pos(r));
    if (vx.open) c.key.push_back(kOut);
    std::sort(c.key.begin(), c.key.end());
    c.key.erase(std::unique(c.key.begin(), c.key.end()), c.key.end());
    bool corner = c.key.size() >= 3;
    for (int r : vx.turning) corner = corner || pos(r) != kOut;
    if (!corner) continue;
    c.point = vx.point;
    out.push_back(std::move(c));
  }
  return out;
}

struct Fit {
  Eigen::Matrix4d H;
  double rms = INFINITY;
  double det = 0, anisotropy = INFINITY;
  Points a, b;
  std::vector<int> image;
};

void measure(Fit& f) {
  const Eigen::Matrix3d J = f.H.topLeftCorner<3, 3>();
  f.det = J.determinant();
  const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3d>(J).singularValues();
  f.anisotropy = sv(2) > 0 ? sv(0) / sv(2) : INFINITY;
}

}  // namespace

TopologyMatch topology_hypotheses(const RegionGraph& ref, const RegionGraph& tgt, const TopologyOptions& o) {
  TopologyMatch out;
  const int nr = static_cast<int>(ref.size());
  if (nr < 2 || tgt.size() < 2) return out;

  // The regions to match: the connected set of uncut regions of largest area. A reference with cut
  // regions (a box cut, a clipped STL) also holds context faces that the cut left whole (the stock's
  // top beside a slot); a machined feature's own faces meet each other at concave edges and the stock
  // at convex ones, so there the largest set of two or more uncut regions joined by concave contacts
  // is tried first. When fewer than two are uncut (a box that took a passage's walls with the part's
  // top and bottom, which lie where a box cut would), the cut ones too: their cut border then counts
  // as open border.
  bool use_cut = false;
  bool concave_only = false;
  for (int r = 0; r < nr; ++r) concave_only = concave_only || ref.regions[static_cast<std::size_t>(r)].cut;
  std::vector<int> comp(static_cast<std::size_t>(nr), -1);
  std::vector<double> comp_area;
  std::vector<int> comp_size;
  auto components = [&] {
    comp.assign(static_cast<std::size_t>(nr), -1);
    comp_area.clear();
    comp_size.clear();
    auto allowed = [&](int r) { return use_cut || !ref.regions[static_cast<std::size_t>(r)].cut; };
    for (int r = 0; r < nr; ++r) {
      if (!allowed(r) || comp[static_cast<std::size_t>(r)] >= 0) continue;
      const int id = static_cast<int>(comp_area.size());
      comp_area.push_back(0);
      comp_size.push_back(0);
      std::vector<int> stack{r};
      comp[static_cast<std::size_t>(r)] = id;
      while (!stack.empty()) {
        const int x = stack.back();
        stack.pop_back();
        comp_area[static_cast<std::size_t>(id)] += ref.regions[static_cast<std::size_t>(x)].area;
        ++comp_size[static_cast<std::size_t>(id)];
        for (const auto& c : ref.contacts[static_cast<std::size_t>(x)])
          if (allowed(c.other) && comp[static_cast<std::size_t>(c.other)] < 0 && (!concave_only || c.angle <= -kSharp)) {
            comp[static_cast<std::size_t>(c.other)] = id;
            stack.push_back(c.other);
          }
      }
    }
    if (comp_area.empty()) return 0;
    if (concave_only)  // a lone region is no set of feature faces here
      for (std::size_t k = 0; k < comp_area.size(); ++k)
        if (comp_size[k] < 2) comp_area[k] = 0;
    const int best = static_cast<int>(std::max_element(comp_area.begin(), comp_area.end()) - comp_area.begin());
    return comp_size[static_cast<std::size_t>(best)] > 1 ? best + 1 : 0;
  };
  int best = components();
  if (best == 0 && concave_only) {
    concave_only = false;
    best = components();
  }
  if (best == 0) {
    use_cut = true;
    best = components();
  }
  if (best == 0) return out;
  --best;
  std::vector<char> in_m(static_cast<std::size_t>(nr), 0);
  std::vector<int> members;
  for (int r = 0; r < nr; ++r)
    if (comp[static_cast<std::size_t>(r)] == best) {
      in_m[static_cast<std::size_t>(r)] = 1;
      members.push_back(r);
    }
  const int n = static_cast<int>(members.size());
  if (n < 2) return out;

  // Degrees within the match, and whole regions (every neighbour matched, no open border).
  std::vector<int> deg(static_cast<std::size_t>(nr), 0);
  std::vector<char> whole(static_cast<std::size_t>(nr), 0);
  for (int r : members) {
    bool w = !ref.regions[static_cast<std::size_t>(r)].open && !ref.regions[static_cast<std::size_t>(r)].cut;
    for (const auto& c : ref.contacts[static_cast<std::size_t>(r)]) {
      if (in_m[static_cast<std::size_t>(c.other)]) ++deg[static_cast<std::size_t>(r)];
      else w = false;
    }
    whole[static_cast<std::size_t>(r)] = w;
  }
  // Match order: the best-connected region first, then always one touching those before.
  std::vector<int> order;
  std::vector<char> placed(static_cast<std::size_t>(nr), 0);
  std::vector<int> parent;  // position (in order) of a matched neighbour, -1 for the first
  while (static_cast<int>(order.size()) < n) {
    int pick = -1, links_best = -1;
    for (int r : members) {
      if (placed[static_cast<std::size_t>(r)]) continue;
      int links = 0;
      for (int q : order) links += ref.contact(r, q) != nullptr;
      if (!order.empty() && links == 0) continue;
      const int score = order.empty() ? deg[static_cast<std::size_t>(r)] : links;
      if (score > links_best || (score == links_best && ref.regions[static_cast<std::size_t>(r)].area > ref.regions[static_cast<std::size_t>(pick)].area)) {
        pick = r;
        links_best = score;
      }
    }
    int par = -1;
    for (std::size_t k = 0; k < order.size() && par < 0; ++k)
      if (ref.contact(pick, order[k])) par = static_cast<int>(k);
    order.push_back(pick);
    parent.push_back(par);
    placed[static_cast<std::size_t>(pick)] = 1;
  }
  out.matched = order;
  if (std::getenv("FE_DEBUG_TOPOLOGY")) {
    for (int r = 0; r < nr; ++r) {
      const auto& g = ref.regions[static_cast<std::size_t>(r)];
      std::fprintf(stderr, "topology: reference region %d%s: %s, area %.3g, centroid (%.2f %.2f %.2f)%s%s%s, contacts", r, in_m[static_cast<std::size_t>(r)] ? " (matched)" : "",
                   g.planar ? "planar" : "curved", g.area, g.centroid.x(), g.centroid.y(), g.centroid.z(), g.open ? ", open" : "", g.cut ? ", cut" : "",
                   whole[static_cast<std::size_t>(r)] ? ", whole" : "");
      for (const auto& c : ref.contacts[static_cast<std::size_t>(r)]) std::fprintf(stderr, " %d (%.0f deg)", c.other, c.angle * 180 / M_PI);
      std::fprintf(stderr, "\n");
    }
  }
  std::vector<int> pos_ref(static_cast<std::size_t>(nr), kOut);
  for (int k = 0; k < n; ++k) pos_ref[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])] = k;
  const std::vector<Corner> ref_corners = corners(ref, order, [&](int r) { return pos_ref[static_cast<std::size_t>(r)]; }, !use_cut);

  // Backtracking over the target's regions.
  const int nt = static_cast<int>(tgt.size());
  std::vector<int> f(static_cast<std::size_t>(n), -1);
  std::vector<int> pos_tgt(static_cast<std::size_t>(nt), kOut);
  // Per set of target regions: matches seen, and the fits of lowest residual (ties kept: the
  // symmetries of a passage's corners fit a turned passage as well; the surface decides).
  struct Slot {
    std::size_t seen = 0;
    double rms = INFINITY, tol = 0;
    std::vector<Fit> fits;
  };
  std::map<std::vector<int>, Slot> by_image;
  auto compatible = [&](int k, int c) {
    const int r = order[static_cast<std::size_t>(k)];
    const auto& rr = ref.regions[static_cast<std::size_t>(r)];
    const auto& tr = tgt.regions[static_cast<std::size_t>(c)];
    if (rr.planar != tr.planar) return false;
    const int td = static_cast<int>(tgt.contacts[static_cast<std::size_t>(c)].size());
    if (whole[static_cast<std::size_t>(r)] ? td != deg[static_cast<std::size_t>(r)] || tr.open : td < deg[static_cast<std::size_t>(r)]) return false;
    for (int j = 0; j < k; ++j) {
      const auto* cr = ref.contact(r, order[static_cast<std::size_t>(j)]);
      const auto* ct = tgt.contact(c, f[static_cast<std::size_t>(j)]);
      if (cr ? !ct || !contacts_agree(*cr, *ct, o.angle_tolerance) : ct != nullptr) return false;
    }
    return true;
  };
  auto fit_match = [&]() {
    std::vector<int> key(f.begin(), f.end());
    std::sort(key.begin(), key.end());
    auto& slot = by_image[key];
    if (++slot.seen > o.max_per_image) return;
    for (int k = 0; k < n; ++k) pos_tgt[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])] = k;
    const std::vector<Corner> tc = corners(tgt, f, [&](int r) { return pos_tgt[static_cast<std::size_t>(r)]; }, false);
    for (int k = 0; k < n; ++k) pos_tgt[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])] = kOut;
    // Pairs: corners whose labels are met once on each side; groups met equally often on both
    // sides are assigned below; centroids of whole regions.
    std::map<std::vector<int>, std::pair<std::vector<int>, std::vector<int>>> groups;
    for (std::size_t i = 0; i < ref_corners.size(); ++i) groups[ref_corners[i].key].first.push_back(static_cast<int>(i));
    for (std::size_t i = 0; i < tc.size(); ++i) {
      const auto it = groups.find(tc[i].key);
      if (it != groups.end()) it->second.second.push_back(static_cast<int>(i));
    }
    std::vector<Eigen::Vector3d> fa, fb;
    std::vector<std::pair<std::vector<int>, std::vector<int>>> ambiguous;
    for (const auto& gr : groups) {
      const auto& [ri, ti] = gr.second;
      if (ri.size() != ti.size() || ri.empty()) continue;
      if (ri.size() == 1) {
        fa.push_back(ref_corners[static_cast<std::size_t>(ri[0])].point);
        fb.push_back(tc[static_cast<std::size_t>(ti[0])].point);
      } else if (ri.size() <= 4) {
        ambiguous.push_back(gr.second);
      }
    }
    for (int k = 0; k < n; ++k)
      if (whole[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])]) {
        fa.push_back(ref.regions[static_cast<std::size_t>(order[static_cast<std::size_t>(k)])].centroid);
        fb.push_back(tgt.regions[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])].centroid);
      }
    // Every assignment of the ambiguous groups (permutations of each), up to 256 of them.
    std::size_t combos = 1;
    std::vector<std::vector<int>> perm(ambiguous.size());
    for (std::size_t g = 0; g < ambiguous.size(); ++g) {
      perm[g].resize(ambiguous[g].first.size());
      std::iota(perm[g].begin(), perm[g].end(), 0);
      std::size_t fact = 1;
      for (std::size_t i = 2; i <= perm[g].size(); ++i) fact *= i;
      combos *= fact;
    }
    while (combos > 256 && !ambiguous.empty()) {  // too many: leave out the largest groups
      std::size_t largest = 0;
      for (std::size_t g = 1; g < ambiguous.size(); ++g)
        if (ambiguous[g].first.size() > ambiguous[largest].first.size()) largest = g;
      std::size_t fact = 1;
      for (std::size_t i = 2; i <= perm[largest].size(); ++i) fact *= i;
      combos /= fact;
      ambiguous.erase(ambiguous.begin() + static_cast<long>(largest));
      perm.erase(perm.begin() + static_cast<long>(largest));
    }
    std::vector<Fit> fits;
    double tol = 0;  // residuals closer than this tie: 1e-3 of the target points' spread
    for (std::size_t c = 0; c < combos; ++c) {
      std::vector<Eigen::Vector3d> a = fa, b = fb;
      for (std::size_t g = 0; g < ambiguous.size(); ++g)
        for (std::size_t i = 0; i < perm[g].size(); ++i) {
          a.push_back(ref_corners[static_cast<std::size_t>(ambiguous[g].first[i])].point);
          b.push_back(tc[static_cast<std::size_t>(ambiguous[g].second[static_cast<std::size_t>(perm[g][i])])].point);
        }
      Fit fit;
      fit.a.resize(static_cast<Eigen::Index>(a.size()), 3);
      fit.b.resize(static_cast<Eigen::Index>(b.size()), 3);
      for (std::size_t i = 0; i < a.size(); ++i) {
        fit.a.row(static_cast<Eigen::Index>(i)) = a[i].transpose();
        fit.b.row(static_cast<Eigen::Index>(i)) = b[i].transpose();
      }
      if (fit_affine(fit.a, fit.b, &fit.H, &fit.rms)) {
        measure(fit);
        fit.image = f;
        tol = 1e-3 * std::sqrt((fit.b.rowwise() - fit.b.colwise().mean()).rowwise().squaredNorm().mean());
        fits.push_back(std::move(fit));
      }
      for (std::size_t g = 0; g < perm.size(); ++g)  // next assignment (odometer over the groups)
        if (std::next_permutation(perm[g].begin(), perm[g].end())) break;
    }
    if (fits.empty()) {
      ++out.degenerate;
      return;
    }
    double low = INFINITY;
    for (const Fit& x : fits) low = std::min(low, x.rms);
    if (std::getenv("FE_DEBUG_TOPOLOGY")) {
      std::fprintf(stderr, "topology match");
      for (int x : f) std::fprintf(stderr, " %d", x);
      std::fprintf(stderr, ": %zu fixed, %zu ambiguous groups, %zu fits, rms %.3g\n", fa.size(), ambiguous.size(), fits.size(), low);
    }
    if (low < slot.rms - tol) {
      slot.fits.clear();
      slot.rms = low;
      slot.tol = tol;
    } else if (low > slot.rms + slot.tol) {
      return;
    }
    for (Fit& x : fits) {
      if (x.rms > slot.rms + slot.tol || slot.fits.size() >= kMaxTies) continue;
      bool seen = false;  // the same transform from another assignment
      for (const Fit& y : slot.fits) seen = seen || (x.H - y.H).norm() <= 1e-6 * (1 + x.H.norm());
      if (!seen) slot.fits.push_back(std::move(x));
    }
  };

  std::vector<std::size_t> cursor(static_cast<std::size_t>(n), 0);
  std::vector<std::vector<int>> cands(static_cast<std::size_t>(n));
  std::vector<char> used(static_cast<std::size_t>(nt), 0);
  auto candidates = [&](int k) {
    std::vector<int> c;
    const int par = parent[static_cast<std::size_t>(k)];
    if (par < 0) {
      c.resize(static_cast<std::size_t>(nt));
      std::iota(c.begin(), c.end(), 0);
    } else {
      for (const auto& x : tgt.contacts[static_cast<std::size_t>(f[static_cast<std::size_t>(par)])]) c.push_back(x.other);
    }
    return c;
  };
  int k = 0;
  cands[0] = candidates(0);
  while (k >= 0) {
    if (out.matches >= o.max_matches) {
      out.truncated = true;
      break;
    }
    auto& ck = cands[static_cast<std::size_t>(k)];
    std::size_t& cur = cursor[static_cast<std::size_t>(k)];
    if (f[static_cast<std::size_t>(k)] >= 0) {  // leave the current choice
      used[static_cast<std::size_t>(f[static_cast<std::size_t>(k)])] = 0;
      f[static_cast<std::size_t>(k)] = -1;
    }
    bool advanced = false;
    while (cur < ck.size()) {
      const int c = ck[cur++];
      if (used[static_cast<std::size_t>(c)] || !compatible(k, c)) continue;
      f[static_cast<std::size_t>(k)] = c;
      used[static_cast<std::size_t>(c)] = 1;
      advanced = true;
      break;
    }
    if (!advanced) {
      cur = 0;
      --k;
      continue;
    }
    if (k + 1 == n) {
      ++out.matches;
      fit_match();
      continue;  // next candidate at this depth
    }
    ++k;
    cands[static_cast<std::size_t>(k)] = candidates(k);
    cursor[static_cast<std::size_t>(k)] = 0;
  }

  // Groups in order of residual, each group's fits proper and least stretched first.
  std::vector<Slot*> slots;
  for (auto& e : by_image)
    if (!e.second.fits.empty()) slots.push_back(&e.second);
  std::stable_sort(slots.begin(), slots.end(), [](const Slot* x, const Slot* y) { return x->rms < y->rms; });
  for (Slot* sl : slots)
    std::stable_sort(sl->fits.begin(), sl->fits.end(), [](const Fit& x, const Fit& y) {
      return std::make_tuple(x.det <= 0, x.anisotropy, x.rms) < std::make_tuple(y.det <= 0, y.anisotropy, y.rms);
    });
  // What lies beyond the matched regions (border_agrees): per matched region, the senses of the
  // sharp contacts its image has with target regions outside the image.
  auto beyond = [&](const std::vector<int>& image) {
    std::vector<int> sig(image.size(), 0);
    for (std::size_t k = 0; k < image.size(); ++k)
      for (const auto& c : tgt.contacts[static_cast<std::size_t>(image[k])]) {
        if (std::find(image.begin(), image.end(), c.other) != image.end() || std::abs(c.angle) < kSharp) continue;
        sig[k] |= c.angle > 0 ? 1 : 2;
      }
    return sig;
  };
  // The best group: of the lowest residual, the least stretched (the reference's own instance when
  // the target holds it).
  const Slot* top = nullptr;
  for (const Slot* sl : slots)
    if (!top || sl->rms < top->rms - top->tol ||
        (sl->rms <= top->rms + top->tol && sl->fits[0].anisotropy < top->fits[0].anisotropy - 1e-9))
      top = sl;
  const std::vector<int> norm = top ? beyond(top->fits[0].image) : std::vector<int>{};
  int group = 0;
  for (Slot* sl : slots) {
    if (out.hypotheses.size() >= o.max_hypotheses) break;
    bool agrees = false;  // some fit of the group sees no sense beyond a region that the best does not
    for (const Fit& x : sl->fits) {
      const std::vector<int> sig = beyond(x.image);
      bool ok = true;
      for (std::size_t k = 0; k < sig.size(); ++k) ok = ok && (sig[k] & ~norm[k]) == 0;
      agrees = agrees || ok;
    }
    for (Fit& x : sl->fits) {
      TopologyHypothesis h;
      h.H = x.H;
      h.residual = x.rms;
      h.group = group;
      h.border_agrees = agrees;
      h.ref_points = std::move(x.a);
      h.tgt_points = std::move(x.b);
      h.image = std::move(x.image);
      out.hypotheses.push_back(std::move(h));
    }
    ++group;
  }
  return out;
}

}  // namespace fe
