// Hypothesis scoring and the acceptance checks (hypothesis.h).
#include "hypothesis.h"

#include <Eigen/Dense>
#include <algorithm>
#include <map>
#include <numeric>
#include <unordered_map>

#ifdef _OPENMP
#include <omp.h>
#else
static int omp_in_parallel() { return 0; }  // built without OpenMP (the sanitizer build): one thread
#endif

namespace fe {

FeatureCore feature_core(const TriangleMesh& reference, const CutFaces& cut) {
  FeatureCore c;
  if (!cut.any_side_cut()) return c;
  const Eigen::Vector3d lo = reference.vertices.colwise().minCoeff(), hi = reference.vertices.colwise().maxCoeff();
  c.lo = lo;
  c.hi = hi;
  for (int a = 0; a < 3; ++a) {
    const double m = kContextMargin * (hi(a) - lo(a));
    if (cut.cut_sides[static_cast<std::size_t>(2 * a)]) c.lo(a) = lo(a) + m;
    if (cut.cut_sides[static_cast<std::size_t>(2 * a + 1)]) c.hi(a) = hi(a) - m;
  }
  c.set = true;
  return c;
}

const char* deformation_outside(const Deformation& df, const Params& p) {
  if (!(df.volume_ratio > 0) || !std::isfinite(df.perspective)) return "degenerate";
  if (df.reflection && !p.allow_reflection) return "reflection";
  if (df.volume_ratio < p.volume_ratio_min || df.volume_ratio > p.volume_ratio_max) return "volume_ratio";
  if (df.scale_min < p.axis_scale_min || df.scale_max > p.axis_scale_max) return "axis_scale";
  if (df.scale_max > p.max_anisotropy * df.scale_min) return "anisotropy";
  if (df.perspective > p.max_perspective) return "perspective";
  return nullptr;
}

bool Evidence::accepted() const {
  return std::all_of(checks.begin(), checks.end(), [](const Check& c) { return c.passed; });
}

std::string Evidence::failed() const {
  for (const Check& c : checks)
    if (!c.passed) return c.name;
  return "";
}

namespace {
// point_error's value for a sample that runs past the end of the target's surface (overhangs()).
constexpr double kOverhang = -1.0;
// Rows of x inside the feature core; all of them when too little would be left. `dense`: x are the
// reference's dense samples (else points whose nearest dense sample decides, with a mask).
std::vector<Eigen::Index> core_rows(const Points& x, const FeatureCore& core, const ShapeDescription::Impl& R, bool dense) {
  std::vector<Eigen::Index> r;
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    bool in;
    if (core.dense_feature) {
      const Eigen::Index j = dense ? i : R.dense_tree->nearest(x.row(i).transpose());
      in = j >= 0 && (*core.dense_feature)[static_cast<std::size_t>(j)] != 0;
    } else {
      in = core.contains(x.row(i).transpose());
    }
    if (in) r.push_back(i);
  }
  // too little left: all is feature (a mask of matched faces is exact: only when it leaves nothing)
  if (core.dense_feature ? r.empty() : r.size() < 20 || r.size() * 10 < static_cast<std::size_t>(x.rows())) {
    r.resize(static_cast<std::size_t>(x.rows()));
    std::iota(r.begin(), r.end(), Eigen::Index{0});
  }
  return r;
}
}  // namespace

HypothesisScorer::HypothesisScorer(const ShapeDescription::Impl& R, const ShapeDescription::Impl& T, const Params& p,
                                   const FeatureCore& core)
    : R_(R), T_(T), p_(p), L_(R.L) {
  core_keys_ = core_rows(R.keys, core, R, false);
  core_dense_ = core_rows(R.dense.points, core, R, true);
  if (std::getenv("FE_DEBUG") && core.set)
    std::fprintf(stderr, "debug: feature core (%.1f %.1f %.1f)..(%.1f %.1f %.1f): %zu of %ld key points, %zu of %zu dense samples\n", core.lo.x(), core.lo.y(),
                 core.lo.z(), core.hi.x(), core.hi.y(), core.hi.z(), core_keys_.size(), static_cast<long>(R.keys.rows()), core_dense_.size(), R.dense.size());
  // Points that judge a transform: the reference key points (paper) plus a fixed subsample of the
  // reference's dense samples, so that a transform must lay the whole feature on the target, not only
  // its corners; each with its normal, which must agree with the target's.
  {
    const std::vector<Eigen::Index> kr = stride_subset(core_keys_, 300);
    const std::vector<Eigen::Index> dr = stride_subset(core_dense_, 300);
    eval_pts_.resize(static_cast<Eigen::Index>(kr.size() + dr.size()), 3);
    eval_nrm_.resize(eval_pts_.rows(), 3);
    Eigen::Index k = 0;
    for (Eigen::Index i : kr) { eval_pts_.row(k) = R.keys.row(i); eval_nrm_.row(k++) = R.key_normals.row(i); }
    for (Eigen::Index i : dr) { eval_pts_.row(k) = R.dense.points.row(i); eval_nrm_.row(k++) = R.dense_normals.row(i); }
  }
  // Samples of faces that reach the reference's border (they may run past the end of the target's),
  // and their distance to their own face's part of the border.
  if (core.open_border && core.open_border_face && core.open_border->rows() > 0 && p.max_overhang > 0 &&
      core.open_border_face->size() == static_cast<std::size_t>(core.open_border->rows()) && R.dense.face_ids.size() == R.dense.points.rows()) {
    std::map<int, std::vector<Eigen::Index>> of_face;
    for (Eigen::Index k = 0; k < core.open_border->rows(); ++k) of_face[(*core.open_border_face)[static_cast<std::size_t>(k)]].push_back(k);
    std::map<int, std::unique_ptr<KdTree3>> trees;
    for (const auto& [f, rows] : of_face) {
      Points P(static_cast<Eigen::Index>(rows.size()), 3);
      for (std::size_t k = 0; k < rows.size(); ++k) P.row(static_cast<Eigen::Index>(k)) = core.open_border->row(rows[k]);
      trees[f] = std::make_unique<KdTree3>(P);
    }
    open_dense_.assign(static_cast<std::size_t>(R.dense.points.rows()), 0);
    border_dist_.assign(static_cast<std::size_t>(R.dense.points.rows()), INFINITY);
    bool any = false;
    for (Eigen::Index i = 0; i < R.dense.points.rows(); ++i) {
      const int f = R.dense.face_ids(i);
      const auto it = f > 0 ? trees.find(f) : trees.end();
      double d2;
      if (it == trees.end() || it->second->nearest(R.dense.points.row(i).transpose(), &d2) < 0) continue;
      open_dense_[static_cast<std::size_t>(i)] = 1;
      border_dist_[static_cast<std::size_t>(i)] = std::sqrt(d2);
      any = true;
    }
    if (!any) {
      open_dense_.clear();
      border_dist_.clear();
    }
  }
  if (!open_dense_.empty()) {
    eval_open_.assign(static_cast<std::size_t>(eval_pts_.rows()), 0);
    eval_border_dist_.assign(static_cast<std::size_t>(eval_pts_.rows()), INFINITY);
    eval_face_.assign(static_cast<std::size_t>(eval_pts_.rows()), 0);
    for (Eigen::Index k = 0; k < eval_pts_.rows(); ++k) {
      const int j = R.dense_tree->nearest(eval_pts_.row(k).transpose());
      if (j < 0) continue;
      eval_open_[static_cast<std::size_t>(k)] = open_dense_[static_cast<std::size_t>(j)];
      eval_border_dist_[static_cast<std::size_t>(k)] = border_dist_[static_cast<std::size_t>(j)];
      eval_face_[static_cast<std::size_t>(k)] = R.dense.face_ids(j);
    }
  }
  normal_penalty_ = 2.0 * p.accept_error * L_;
  dense_rows_ = stride_subset(core_dense_, 1500);
  coarse_rows_ = stride_subset(core_dense_, 500);
  rlo_ = R.keys.colwise().minCoeff();
  rhi_ = R.keys.colwise().maxCoeff();
  screen_rows_ = stride_rows(eval_pts_.rows(), 40);
  tkey_tree_ = std::make_unique<KdTree3>(T.keys);
  {  // the axis of revolution, on the samples the refinement fits (refine.cpp)
    const std::vector<Eigen::Index> rows = stride_subset(core_dense_, 800);
    Points x(static_cast<Eigen::Index>(rows.size()), 3), n(static_cast<Eigen::Index>(rows.size()), 3);
    for (std::size_t k = 0; k < rows.size(); ++k) {
      x.row(static_cast<Eigen::Index>(k)) = R.dense.points.row(rows[k]);
      n.row(static_cast<Eigen::Index>(k)) = R.dense_normals.row(rows[k]);
    }
    sym_ = detect_axisymmetry(x, n, L_);
  }
  // Free space in front of the reference's surface (clearance.h), from its core samples.
  const KdTree3& rtree = *R.dense_tree;
  // (the rays leave at the box of the feature's faces when they are known: what a box cut took along
  // around them differs from instance to instance)
  Eigen::Vector3d flo = R.box_min, fhi = R.box_max;
  if (core.dense_feature && !core_dense_.empty()) {
    flo.setConstant(INFINITY);
    fhi.setConstant(-INFINITY);
    for (const Eigen::Index i : core_dense_) {
      flo = flo.cwiseMin(R.dense.points.row(i).transpose());
      fhi = fhi.cwiseMax(R.dense.points.row(i).transpose());
    }
  }
  clearance_ = std::make_unique<Clearance>(R.dense.points, R.dense_normals, stride_subset(core_dense_, 400),
                                           [&rtree, &R](const Eigen::Vector3d& x) -> Eigen::Vector3d {
                                             const int j = rtree.nearest(x);
                                             return j < 0 ? Eigen::Vector3d::Constant(INFINITY) : Eigen::Vector3d(R.dense.points.row(j).transpose());
                                           },
                                           flo, fhi, R.dense_h, p.clearance_margin * L_);
  // Whole faces (clearance.h): reference faces all of whose samples are feature, with enough samples
  // to measure their area, must land on whole target faces.
  if (R.dense.face_ids.size() && T.dense.face_ids.size() && p.max_partial_faces < 1) {
    const int nf = std::max(R.dense.face_ids.maxCoeff(), 0) + 1;
    std::vector<int> in_core(static_cast<std::size_t>(nf), 0), all(static_cast<std::size_t>(nf), 0);
    for (Eigen::Index i = 0; i < R.dense.face_ids.size(); ++i) ++all[static_cast<std::size_t>(std::max(R.dense.face_ids(i), 0))];
    for (const Eigen::Index i : core_dense_)
      if (!core.dense_feature || (*core.dense_feature)[static_cast<std::size_t>(i)] == 1) ++in_core[static_cast<std::size_t>(std::max(R.dense.face_ids(i), 0))];
    whole_faces_.checked.assign(static_cast<std::size_t>(nf), 0);
    for (int f = 1; f < nf; ++f) whole_faces_.checked[static_cast<std::size_t>(f)] = all[static_cast<std::size_t>(f)] >= 20 && in_core[static_cast<std::size_t>(f)] == all[static_cast<std::size_t>(f)];
    whole_faces_.reference = &R.dense;
    whole_faces_.rows = core_dense_;
    whole_faces_.reference_spacing = R.dense_h;
    whole_faces_.target_faces = &T.dense.face_ids;
    std::vector<std::vector<int>> on_face(static_cast<std::size_t>(std::max(T.dense.face_ids.maxCoeff(), 0) + 1));
    for (Eigen::Index j = 0; j < T.dense.face_ids.size(); ++j)
      if (T.dense.face_ids(j) > 0) on_face[static_cast<std::size_t>(T.dense.face_ids(j))].push_back(static_cast<int>(j));
    whole_faces_.target_area.resize(on_face.size());
    face_rows_.resize(on_face.size());
    for (std::size_t g = 0; g < on_face.size(); ++g) {
      whole_faces_.target_area[g] = static_cast<double>(on_face[g].size()) * T.dense_h * T.dense_h;
      for (const Eigen::Index k : stride_rows(static_cast<Eigen::Index>(on_face[g].size()), 150)) face_rows_[g].push_back(on_face[g][static_cast<std::size_t>(k)]);
    }
    whole_faces_.target_nearest = [this](const Eigen::Vector3d& y, double* d) {
      int j;
      *d = target_distance(y, &j);
      return j;
    };
    // Cylinders (a hole's, a boss's wall) that reach the open border (picked faces' edge, a left-out
    // own face) where they end along their axis may go on past it on an instance where they leave the
    // part there: a hole through a taller boss. Not planes: a plane goes on every way along itself,
    // and a corner step's floor and wall laid sideways in a through slot would go on "through" it too
    // (corner_step_block, stretched: 3 false matches with planes allowed).
    if (core.open_border && core.open_border_face && core.open_border_face->size() == static_cast<std::size_t>(core.open_border->rows())) {
      std::vector<int> idx;
      std::vector<float> d2;
      // the axis of each checked face whose normals all lie across one direction (a cylinder)
      std::vector<Eigen::Matrix3d> nn(static_cast<std::size_t>(nf), Eigen::Matrix3d::Zero());
      std::vector<int> count(static_cast<std::size_t>(nf), 0);
      for (Eigen::Index i = 0; i < R.dense.face_ids.size(); ++i) {
        const int f = R.dense.face_ids(i);
        if (f <= 0 || f >= nf || !whole_faces_.checked[static_cast<std::size_t>(f)]) continue;
        const Eigen::Vector3d n = R.dense_normals.row(i).transpose();
        nn[static_cast<std::size_t>(f)] += n * n.transpose();
        ++count[static_cast<std::size_t>(f)];
      }
      std::map<int, Eigen::Vector3d> axis;
      for (int f = 1; f < nf; ++f) {
        if (count[static_cast<std::size_t>(f)] < 20) continue;
        const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(nn[static_cast<std::size_t>(f)] / count[static_cast<std::size_t>(f)]);
        if (es.eigenvalues()(0) < 0.01 && es.eigenvalues()(1) > 0.05) axis[f] = es.eigenvectors().col(0);
      }
      std::map<int, std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>>> ends;
      for (Eigen::Index k = 0; k < core.open_border->rows(); ++k) {
        const int f = (*core.open_border_face)[static_cast<std::size_t>(k)];
        if (f <= 0 || f >= nf || !whole_faces_.checked[static_cast<std::size_t>(f)] || !axis.count(f)) continue;
        const Eigen::Vector3d b = core.open_border->row(k).transpose();
        R.dense_tree->radius(b, 3.0 * R.dense_h, idx, d2);
        Eigen::Vector3d m = Eigen::Vector3d::Zero(), n = Eigen::Vector3d::Zero();
        int c = 0;
        for (const int i : idx)
          if (R.dense.face_ids(i) == f) {
            m += R.dense.points.row(i).transpose();
            n += R.dense_normals.row(i).transpose();
            ++c;
          }
        if (c < 3) continue;
        m /= c;
        Eigen::Vector3d t = b - m;
        if (n.norm() > 0) t -= t.dot(n.normalized()) * n.normalized();
        if (!(t.norm() > 0.2 * R.dense_h)) continue;
        const Eigen::Vector3d& a = axis[f];
        const double along = t.normalized().dot(a);
        if (std::abs(along) < 0.9) continue;  // a border along the cylinder, not across its end
        ends[f].emplace_back(b, along > 0 ? a : Eigen::Vector3d(-a));
      }
      for (auto& [f, pts] : ends) {
        BorderEnd& e = border_ends_[f];
        e.points.resize(static_cast<Eigen::Index>(pts.size()), 3);
        e.outward.resize(e.points.rows(), 3);
        for (std::size_t k = 0; k < pts.size(); ++k) {
          e.points.row(static_cast<Eigen::Index>(k)) = pts[k].first.transpose();
          e.outward.row(static_cast<Eigen::Index>(k)) = pts[k].second.transpose();
        }
        std::vector<Eigen::Index> rows;
        for (const Eigen::Index i : core_dense_)
          if (R.dense.face_ids(i) == f) rows.push_back(i);
        for (const Eigen::Index k : stride_rows(static_cast<Eigen::Index>(rows.size()), 2000)) e.rows.push_back(rows[static_cast<std::size_t>(k)]);
      }
      if (!border_ends_.empty()) {
        target_face_all_ = std::move(on_face);
        whole_faces_.goes_on_through = [this](const Eigen::Matrix4d& H, int f, int g) { return goes_on_through(H, f, g); };
      }
    }
  }
  // A clipped region's through ends (FeatureCore::through_ends): judged on a target with B-rep faces.
  if (core.through_ends && core.through_outward && core.through_ends->rows() > 0 && core.through_outward->rows() == core.through_ends->rows() &&
      T.dense.face_ids.size() && T.dense.face_ids.maxCoeff() > 0 && p.max_partial_faces < 1) {
    through_ends_ = *core.through_ends;
    through_outward_ = *core.through_outward;
    through_rows_ = stride_subset(core_dense_, 4000);
    if (target_face_all_.empty()) {
      target_face_all_.resize(static_cast<std::size_t>(T.dense.face_ids.maxCoeff() + 1));
      for (Eigen::Index j = 0; j < T.dense.face_ids.size(); ++j)
        if (T.dense.face_ids(j) > 0) target_face_all_[static_cast<std::size_t>(T.dense.face_ids(j))].push_back(static_cast<int>(j));
    }
  }
}

bool HypothesisScorer::goes_on_through(const Eigen::Matrix4d& H, int f, int g) const {
  const auto it = border_ends_.find(f);
  if (it == border_ends_.end() || it->second.rows.empty() || g <= 0 || static_cast<std::size_t>(g) >= target_face_all_.size()) return false;
  const BorderEnd& e = it->second;
  // f's end at the border, and f itself, where H puts them
  Points B(e.points.rows(), 3), U(e.points.rows(), 3), Y(static_cast<Eigen::Index>(e.rows.size()), 3);
  for (Eigen::Index k = 0; k < e.points.rows(); ++k) {
    const Eigen::Vector3d x = e.points.row(k).transpose();
    B.row(k) = apply_transform(H, x).transpose();
    U.row(k) = (transform_jacobian(H, x) * e.outward.row(k).transpose()).normalized().transpose();
  }
  for (std::size_t k = 0; k < e.rows.size(); ++k) Y.row(static_cast<Eigen::Index>(k)) = apply_transform(H, R_.dense.points.row(e.rows[k]).transpose()).transpose();
  if (!B.allFinite() || !U.allFinite() || !Y.allFinite()) return false;
  const double s = std::cbrt(std::abs(transform_jacobian(H, R_.dense.points.row(e.rows[0]).transpose()).determinant()));
  return goes_on_past(B, U, Y, 2.5 * std::max(T_.dense_h, s * R_.dense_h), g, f) == 1;
}

int HypothesisScorer::goes_on_past(const Points& B, const Points& U, const Points& Y, double cover, int g, int f) const {
  if (B.rows() == 0 || Y.rows() == 0 || g <= 0 || static_cast<std::size_t>(g) >= target_face_all_.size()) return 0;
  const KdTree3 ytree(Y), btree(B);
  // every sample of g that the mapped reference does not cover lies past its end
  const std::vector<int>& gs = target_face_all_[static_cast<std::size_t>(g)];
  std::vector<std::pair<double, int>> past;  // (how far past the end, target row)
  std::size_t uncovered = 0;
  for (const Eigen::Index k : stride_rows(static_cast<Eigen::Index>(gs.size()), 2000)) {
    const int j = gs[static_cast<std::size_t>(k)];
    const Eigen::Vector3d y = T_.dense.points.row(j).transpose();
    if (ytree.nearest_within(y, cover) >= 0) continue;
    ++uncovered;
    const int b = btree.nearest(y);
    const double d = (y - B.row(b).transpose()).dot(U.row(b).transpose());
    if (d > 0) past.emplace_back(d, j);
  }
  if (uncovered == 0) return -1;
  if (static_cast<double>(past.size()) < 0.9 * static_cast<double>(uncovered)) return 0;
  // where g ends: the part's surface beside its farthest samples faces the way g went
  double far = 0;
  for (const auto& pj : past) far = std::max(far, pj.first);
  std::vector<int> idx;
  std::vector<float> d2;
  int ahead = 0, back = 0;
  for (const auto& pj : past) {
    if (pj.first < far - 2.0 * T_.dense_h) continue;
    const Eigen::Vector3d y = T_.dense.points.row(pj.second).transpose();
    const Eigen::Vector3d u = U.row(btree.nearest(y)).transpose();
    T_.dense_tree->radius(y, 3.0 * T_.dense_h, idx, d2);
    for (const int q : idx) {
      if (T_.dense.face_ids(q) == g) continue;
      const double c = T_.dense_normals.row(q).dot(u);
      if (c > 0.7) ++ahead;
      else if (c < -0.7) ++back;
    }
  }
  if (std::getenv("FE_DEBUG"))
    std::fprintf(stderr, "debug: face %d on target face %d: %zu of %zu uncovered samples past its end, end faces %d ahead, %d back\n", f, g,
                 past.size(), uncovered, ahead, back);
  return ahead >= 3 && 4 * back < ahead ? 1 : 0;
}

double HypothesisScorer::through_share(const Eigen::Matrix4d& H, double tol) const {
  if (through_ends_.rows() == 0 || through_rows_.empty()) return 0;
  Points B(through_ends_.rows(), 3), U(through_ends_.rows(), 3), Y(static_cast<Eigen::Index>(through_rows_.size()), 3);
  for (Eigen::Index k = 0; k < B.rows(); ++k) {
    const Eigen::Vector3d x = through_ends_.row(k).transpose();
    B.row(k) = apply_transform(H, x).transpose();
    U.row(k) = (transform_jacobian(H, x) * through_outward_.row(k).transpose()).normalized().transpose();
  }
  for (std::size_t k = 0; k < through_rows_.size(); ++k)
    Y.row(static_cast<Eigen::Index>(k)) = apply_transform(H, R_.dense.points.row(through_rows_[k]).transpose()).transpose();
  if (!B.allFinite() || !U.allFinite() || !Y.allFinite()) return 1;
  const double s = std::cbrt(std::abs(transform_jacobian(H, through_ends_.row(0).transpose()).determinant()));
  const double h = std::max(T_.dense_h, s * R_.dense_h), reach = 2.0 * h + 0.5 * tol;
  std::map<int, int> verdict;  // target face -> covered whole or goes_on_past
  std::vector<int> idx;
  std::vector<float> d2;
  const KdTree3 ytree(Y);
  int bad = 0;
  for (Eigen::Index k = 0; k < B.rows(); ++k) {
    // Around each end point: the plane itself, facing ahead (the region ends where the part does, as
    // where it was clipped out), or the target faces going on across it (normals across the outward
    // direction: a hole's wall), each of which must be covered whole or go on past the end and leave
    // the part (a through hole's exit), not end on a floor facing back or stop short; or, in free space, beyond such a
    // plane (the instance passes through a thinner wall, and the rest is the fit's to judge).
    T_.dense_tree->radius(B.row(k).transpose(), reach, idx, d2);
    int ahead = 0, back = 0;
    std::vector<int> faces;
    for (const int q : idx) {
      const double c = T_.dense_normals.row(q).dot(U.row(k));
      if (c > 0.7) ++ahead;
      else if (c < -0.7) ++back;
      const int g = T_.dense.face_ids(q);
      if (g > 0 && std::abs(c) < 0.5 && std::find(faces.begin(), faces.end(), g) == faces.end()) faces.push_back(g);
    }
    bool ok = ahead > 0 && back < ahead;
    if (idx.empty()) {  // in free space: past the plane where the instance leaves the part sooner (a thinner wall)?
      int j;
      const double d = target_distance(B.row(k).transpose(), &j);
      ok = j >= 0 && std::isfinite(d) && T_.dense_normals.row(j).dot(U.row(k)) > 0.7 &&
           (B.row(k) - T_.dense.points.row(j)).dot(T_.dense_normals.row(j)) > 0;
    }
    if (!ok && back == 0 && !faces.empty()) {
      ok = true;
      for (const int g : faces) {
        auto it = verdict.find(g);
        if (it == verdict.end()) {
          // covered for kWholeFaceFill of its samples, as the whole-faces check asks of picked faces:
          // the instance's own face, of other proportions (a drilled hole a little deeper)
          const std::vector<int>& gs = target_face_all_[static_cast<std::size_t>(g)];
          const std::vector<Eigen::Index> rows = stride_rows(static_cast<Eigen::Index>(gs.size()), 400);
          std::size_t covered = 0;
          for (const Eigen::Index r : rows) covered += ytree.nearest_within(T_.dense.points.row(gs[static_cast<std::size_t>(r)]).transpose(), 2.5 * h) >= 0;
          const bool whole = static_cast<double>(covered) >= kWholeFaceFill * static_cast<double>(rows.size());
          it = verdict.emplace(g, whole ? 1 : goes_on_past(B, U, Y, 2.5 * h, g, 0)).first;
        }
        ok = ok && it->second == 1;
      }
    }
    if (!ok && std::getenv("FE_DEBUG"))
      std::fprintf(stderr, "debug:   end %ld at (%.1f %.1f %.1f) out (%.2f %.2f %.2f): %zu near, %d ahead, %d back, %zu faces going on%s\n", static_cast<long>(k),
                   B(k, 0), B(k, 1), B(k, 2), U(k, 0), U(k, 1), U(k, 2), idx.size(), ahead, back, faces.size(), faces.empty() ? "" : (" (" + std::to_string(verdict[faces[0]]) + ")").c_str());
    bad += ok ? 0 : 1;
  }
  if (std::getenv("FE_DEBUG")) {
    const Eigen::Vector3d lo = B.colwise().minCoeff().transpose(), hi = B.colwise().maxCoeff().transpose();
    std::fprintf(stderr, "debug: through ends (%.1f %.1f %.1f)..(%.1f %.1f %.1f): %d of %ld neither on the plane nor going on out of the part\n", lo.x(), lo.y(),
                 lo.z(), hi.x(), hi.y(), hi.z(), bad, static_cast<long>(B.rows()));
  }
  return static_cast<double>(bad) / static_cast<double>(B.rows());
}

HypothesisScorer::~HypothesisScorer() = default;

double HypothesisScorer::target_distance(const Eigen::Vector3d& y, int* j) const {
  double d2;
  const int k = T_.dense_tree->nearest(y, &d2);
  if (j) *j = k;
  return k < 0 ? INFINITY : std::sqrt(d2);
}

bool HypothesisScorer::overhangs(const Eigen::Vector3d& y, const Eigen::Vector3d& nm, int j, double s) const {
  if (j < 0) return false;
  const double tol = p_.accept_error * L_ * s;
  const Eigen::Vector3d q = T_.dense.points.row(j);
  // in free space: in front of (or beside) every nearby target sample, behind none
  thread_local std::vector<int> idx;
  thread_local std::vector<float> d2;
  T_.dense_tree->knn(y, 8, idx, d2);
  for (const int k : idx)
    if ((y - T_.dense.points.row(k).transpose()).dot(T_.dense_normals.row(k).transpose()) < -tol) return false;
  // the step from y toward q within y's own tangent plane ends where the target surface ends (q
  // itself may lie on the face beyond the end: the part's bottom around a hole's rim) ...
  Eigen::Vector3d u = q - y;
  u -= u.dot(nm) * nm;
  const Eigen::Vector3d z = y + u;
  // ... beside target samples of the same facing whose tangent planes pass through y (a hole of
  // the wrong radius lies off them along the normal)
  T_.dense_tree->radius(z, 2.0 * T_.dense_h + 0.5 * tol, idx, d2);
  for (const int k : idx) {
    const Eigen::Vector3d n = T_.dense_normals.row(k);
    if (n.dot(nm) >= 0.9 && std::abs((y - T_.dense.points.row(k).transpose()).dot(n)) <= tol) return true;
  }
  return false;
}

bool HypothesisScorer::bounds_ok(const Eigen::Matrix4d& H, double* scale) const {
  const Deformation df = deformation(H, rlo_, rhi_);
  if (deformation_outside(df, p_)) return false;
  if (scale) *scale = std::cbrt(df.volume_ratio);
  return true;
}

// Paper 3.8 (4)-(5): map the reference key points, error to the nearest dense target point;
// the error of H is the maximum (or error_quantile) over them, divided by the scale of H.
// Error of H at evaluation point i, in reference units (divided by the scale s of H): distance to
// the target surface, or at least the normal penalty where the normals disagree; +inf off the
// target. With `capped`, errors of the normal penalty or more may come back as the penalty (for the
// sums that truncate there anyway): the same sums, with a search that stops at the penalty. Without
// `overhang`, a sample past the end of the target's surface is not tested for it (overhangs()) and
// counts as off the target.
double HypothesisScorer::point_error(const Eigen::Matrix4d& H, Eigen::Index i, double s, bool capped, bool overhang) const {
  const Eigen::Vector3d x = eval_pts_.row(i);
  const Eigen::Vector3d y = apply_transform(H, x);
  int j;
  double e;
  if (capped) {
    e = surface_distance_capped(T_, y, normal_penalty_ * s, &j) / s;
    if (!std::isfinite(e)) return INFINITY;
  } else {
    e = surface_distance(T_, y, &j) / s;
    if (!std::isfinite(e) || j < 0) return INFINITY;
  }
  const Eigen::Vector3d nm = (transform_jacobian(H, x).inverse().transpose() * eval_nrm_.row(i).transpose()).normalized();
  facing(y, nm, s, e, j);
  // (just past the end, the nearest target sample may be the face beyond it, of another facing; a
  // sample on the surface whose normal disagrees only at a crease is not off it)
  if (overhang && !eval_open_.empty() && eval_open_[static_cast<std::size_t>(i)] &&
      (j < 0 || e > p_.accept_error * L_ || (nm.dot(T_.dense_normals.row(j)) < 0.5 && e * s > 2 * T_.dense_h))) {
    const int k = T_.dense_tree->nearest(y);
    if (overhangs(y, nm, k, s)) return kOverhang;
  }
  if (j < 0) return normal_penalty_;  // (capped: farther than the penalty)
  if (nm.dot(T_.dense_normals.row(j)) < 0.5) e = std::max(e, normal_penalty_);
  return e;
}

// A mapped sample on the target's surface whose nearest target sample faces the opposite way (two
// solids that touch: the development case occt_cooker_burners, a box cut through a hob plate lying
// on a worktop, where every fit of the burners was rejected with half the contact faces' samples at
// the normal penalty) is measured to the coincident surface that faces its way, if one lies within
// two sample spacings. `e` is in reference units (divided by s). A wall thinner than that is one surface too.
void HypothesisScorer::facing(const Eigen::Vector3d& y, const Eigen::Vector3d& nm, double s, double& e, int& j) const {
  const double reach = 2 * T_.dense_h;
  // (only a surface facing the opposite way: at a crease the nearest sample of the other face is not
  // a coincident surface)
  if (j < 0 || !(e * s <= reach) || nm.dot(T_.dense_normals.row(j)) > -0.5 || !nm.allFinite()) return;
  int k;
  const double f = facing_surface_distance(T_, y, nm, reach, &k);
  if (k >= 0) e = f / s, j = k;
}

bool HypothesisScorer::point_errors(const Eigen::Matrix4d& H, double s, double sum_limit, std::vector<double>& errs, bool capped) const {
  if (!std::isfinite(sum_limit) && !omp_in_parallel()) {  // nothing to stop early for: all threads
    errs.assign(static_cast<std::size_t>(eval_pts_.rows()), 0.0);
#pragma omp parallel for schedule(static)
    for (Eigen::Index i = 0; i < eval_pts_.rows(); ++i) errs[static_cast<std::size_t>(i)] = point_error(H, i, s, capped);
    for (const double e : errs)
      if (!std::isfinite(e)) return false;
    return true;
  }
  errs.clear();
  double sum = 0;
  for (Eigen::Index i = 0; i < eval_pts_.rows(); ++i) {
    const double e = point_error(H, i, s, capped);
    if (!std::isfinite(e)) return false;
    errs.push_back(e);
    sum += e == kOverhang ? p_.accept_error * L_ : std::min(e, normal_penalty_);
    if (sum > sum_limit) return false;  // cannot beat the best any more
  }
  return true;
}

void HypothesisScorer::keep_truncations(std::vector<double>& errs, const std::vector<int>& face, const std::vector<double>& dist, double on,
                                        double penalty) const {
  std::unordered_map<int, std::pair<double, double>> lim;  // face -> (nearest on the target, farthest overhanging) from the border
  for (std::size_t k = 0; k < errs.size(); ++k) {
    if (!std::isfinite(dist[k])) continue;
    auto it = lim.emplace(face[k], std::make_pair(INFINITY, -INFINITY)).first;
    if (errs[k] == kOverhang) it->second.second = std::max(it->second.second, dist[k]);
    else if (errs[k] <= on) it->second.first = std::min(it->second.first, dist[k]);
  }
  // (samples within the acceptance tolerance past the target's end still count as on it)
  const double margin = p_.accept_error * L_ + 2.0 * R_.dense_h;
  for (std::size_t k = 0; k < errs.size(); ++k) {
    if (errs[k] != kOverhang) continue;
    const auto it = lim.find(face[k]);
    if (it != lim.end() && it->second.second > it->second.first + margin) errs[k] = penalty;
  }
}

// The errors of overhanging samples (kOverhang): left out while they are at most max_overhang of all,
// else counted at the normal penalty (off the target, as any sample that lies nowhere near it).
double HypothesisScorer::overhang_share(const std::vector<double>& errs) const {
  if (errs.empty()) return 0;
  const auto n = std::count(errs.begin(), errs.end(), kOverhang);
  return static_cast<double>(n) / static_cast<double>(errs.size());
}

double HypothesisScorer::cost(const Eigen::Matrix4d& H, double limit) const {
  double s;
  if (!bounds_ok(H, &s)) return INFINITY;
  thread_local std::vector<double> buf;
  if (!point_errors(H, s, std::isfinite(limit) ? limit * static_cast<double>(eval_pts_.rows()) : INFINITY, buf, true)) return INFINITY;
  // an overhanging sample costs the acceptance bound: a fit that runs off the target no farther
  // than it must is preferred, and one that overhangs more than max_overhang pays the penalty
  const double over = overhang_share(buf) <= p_.max_overhang ? p_.accept_error * L_ : normal_penalty_;
  double sum = 0;
  for (double e : buf) sum += e == kOverhang ? over : std::min(e, normal_penalty_);
  return sum / static_cast<double>(buf.size());
}

double HypothesisScorer::screen_cost(const Eigen::Matrix4d& H, double s, double limit) const {
  const double n = static_cast<double>(std::max<std::size_t>(1, screen_rows_.size()));
  const double sum_limit = limit * n;
  // No overhang test here: the screen only ranks one-pair placements, and the placements it keeps are
  // costed with the test (cost()). On every screened row the test was about half of a search's
  // instructions (MFCAD 6-6-6-11-13-23's through step, callgrind: 43.6 G with it, 18.7 G without).
  double sum = 0;
  for (const Eigen::Index i : screen_rows_) {
    const double e = point_error(H, i, s, true, false);
    if (!std::isfinite(e)) return INFINITY;
    sum += std::min(e, normal_penalty_);
    if (sum > sum_limit && sum / n > limit) return INFINITY;  // terms are >= 0: the mean can only grow
  }
  return sum / n;
}

double HypothesisScorer::quantile_error(const Eigen::Matrix4d& H) const {
  double s;
  std::vector<double> errs;
  if (!bounds_ok(H, &s) || !point_errors(H, s, INFINITY, errs, false)) return INFINITY;
  if (!eval_open_.empty()) keep_truncations(errs, eval_face_, eval_border_dist_, p_.accept_error * L_, normal_penalty_);
  if (overhang_share(errs) <= p_.max_overhang) {
    errs.erase(std::remove(errs.begin(), errs.end(), kOverhang), errs.end());
    if (errs.empty()) return INFINITY;
  } else {
    for (double& e : errs) e = e == kOverhang ? normal_penalty_ : e;
  }
  const std::size_t q = std::min(errs.size() - 1, static_cast<std::size_t>(p_.error_quantile * static_cast<double>(errs.size())));
  std::nth_element(errs.begin(), errs.begin() + static_cast<long>(q), errs.end());
  return errs[q];
}

bool HypothesisScorer::dense_overhangs(const Eigen::Matrix4d& H, Eigen::Index row, const Eigen::Vector3d& y, double e, int j, double s) const {
  if (!open_dense(row) || j < 0 || !std::isfinite(e)) return false;
  const Eigen::Vector3d x = R_.dense.points.row(row);
  const Eigen::Vector3d nm = (transform_jacobian(H, x).inverse().transpose() * R_.dense_normals.row(row).transpose()).normalized();
  if (!nm.allFinite() || (e <= p_.accept_error * L_ * s && (nm.dot(T_.dense_normals.row(j)) >= 0.5 || e <= 2 * T_.dense_h))) return false;  // on the target
  return overhangs(y, nm, j, s);
}

double HypothesisScorer::rms_on_surface(const Eigen::Matrix4d& H, bool coarse) const {
  const std::vector<Eigen::Index>& rows = coarse ? coarse_rows_ : dense_rows_;
  std::vector<double> e(rows.size());  // on all threads, summed in order
  std::vector<char> over(rows.size(), 0);
  const double s = std::cbrt(std::abs(deformation(H, rlo_, rhi_).volume_ratio));
#pragma omp parallel for schedule(static)
  for (std::size_t k = 0; k < rows.size(); ++k) {
    const Eigen::Vector3d y = apply_transform(H, R_.dense.points.row(rows[k]).transpose());
    int j;
    e[k] = surface_distance(T_, y, &j);
    over[k] = !open_dense_.empty() && s > 0 && dense_overhangs(H, rows[k], y, e[k], j, s);
  }
  // overhanging samples are left out (while at most max_overhang of them)
  const std::size_t no = static_cast<std::size_t>(std::count(over.begin(), over.end(), 1));
  const bool skip = no > 0 && static_cast<double>(no) <= p_.max_overhang * static_cast<double>(rows.size());
  double sq = 0;
  for (std::size_t k = 0; k < e.size(); ++k)
    if (!(skip && over[k])) sq += std::isfinite(e[k]) ? e[k] * e[k] : L_ * L_;
  return std::sqrt(sq / static_cast<double>(std::max<std::size_t>(1, rows.size() - (skip ? no : 0))));
}

namespace {
// The point of the axis of revolution nearest x.
Eigen::Vector3d foot_on_axis(const Symmetry& sym, const Eigen::Vector3d& x) {
  const Eigen::Vector3d a = sym.axis.normalized();
  return sym.point + a.dot(x - sym.point) * a;
}
}  // namespace

bool HypothesisScorer::turns_freely(const Eigen::Matrix4d& H) const {
  if (!sym_.axisymmetric) return false;
  // H's stretches on the axis, at the middle of the reference's key points
  const Eigen::Vector3d sv = Eigen::JacobiSVD<Eigen::Matrix3d>(transform_jacobian(H, foot_on_axis(sym_, 0.5 * (rlo_ + rhi_)))).singularValues();
  return sv(2) > 0 && sv(0) <= kTurnRoundness * sv(2);
}

bool HypothesisScorer::key_agrees(const Eigen::Matrix4d& H, Eigen::Index i, double reach, double s, bool turns, std::vector<int>& near,
                                  std::vector<float>& d2) const {
  const Eigen::Vector3d x = R_.keys.row(i).transpose();
  auto agrees_at = [&](const Eigen::Vector3d& y) {
    tkey_tree_->radius(y, reach, near, d2);
    for (int j : near)
      if (std::abs(T_.key_si(j) - R_.key_si(i)) <= p_.key_si_tolerance) return true;
    return false;
  };
  if (agrees_at(apply_transform(H, x))) return true;
  if (!turns) return false;
  // A surface of revolution leaves the spin free, and where its key points sit on a rim of constant
  // curvature is the tessellation's doing: on an instance they sit at other turns (development case
  // counterbore_bosses, box-cut at ref0.7: the holes fitted to 0.000 L with a score of 0.99 and not
  // one key point agreeing). The key point may agree at any turn about the axis: its circle, in
  // steps of at most `reach` once mapped. Only where H is nearly a similarity (turns_freely): a fit
  // stretched along the axis or across it is judged where it puts the key points, as before, for
  // there they still tell a stretched fit from a true one (FTC-10's drilled hole laid on larger round
  // features, 2.9x across its axis and 1.1x along it: 0.85 of its key points agreed at some turn,
  // two false matches, where a bound on the roundness across the axis alone let them through).
  const Eigen::Vector3d c = foot_on_axis(sym_, x);
  const Eigen::Vector3d u = x - c;
  const double r = u.norm();
  if (!(r * s > 0.5 * reach)) return false;  // on the axis: every turn is the same point
  const Eigen::Vector3d v = sym_.axis.normalized().cross(u);
  const int steps = static_cast<int>(std::min(360.0, std::ceil(2 * M_PI * r * s / reach)));
  for (int k = 1; k < steps; ++k) {
    const double t = 2 * M_PI * k / steps;
    if (agrees_at(apply_transform(H, c + std::cos(t) * u + std::sin(t) * v))) return true;
  }
  return false;
}

Evidence HypothesisScorer::evaluate(const Eigen::Matrix4d& H, double s, bool all) const {
  Evidence ev;
  ev.error = quantile_error(H);
  const double tol = p_.accept_error * L_ * s;
  ev.tolerance = tol;
  // Validation on the dense surfaces: mapped reference samples on the target, normals agreeing.
  ev.mapped.resize(static_cast<Eigen::Index>(dense_rows_.size()), 3);
  bool finite_map = true;  // false when H's plane at infinity cuts the reference feature
  // per row: its error (kOverhang where it overhangs), and whether it lies on the target
  std::vector<double> err(dense_rows_.size()), dist(open_dense_.empty() ? 0 : dense_rows_.size());
  std::vector<int> face(dist.size());
  std::vector<char> is_on(dense_rows_.size(), 0);
  std::vector<double> e2(dense_rows_.size());
  double sq = 0;
  for (std::size_t k = 0; k < dense_rows_.size(); ++k) {
    const Eigen::Vector3d x = R_.dense.points.row(dense_rows_[k]);
    const Eigen::Vector3d y = apply_transform(H, x);
    finite_map = finite_map && y.allFinite();
    ev.mapped.row(static_cast<Eigen::Index>(k)) = y;
    int j;
    double e = surface_distance(T_, y, &j);
    Eigen::Vector3d nm = Eigen::Vector3d::Constant(NAN);  // the mapped normal, where y is on the target
    if (std::isfinite(e) && j >= 0) {
      nm = (transform_jacobian(H, x).inverse().transpose() * R_.dense_normals.row(dense_rows_[k]).transpose()).normalized();
      if (s > 0) {
        double es = e / s;
        facing(y, nm, s, es, j);
        e = es * s;
      }
    }
    e2[k] = std::isfinite(e) ? e * e : tol * tol * 100;
    sq += e2[k];
    err[k] = std::isfinite(e) ? e : tol * 10;
    if (!dist.empty()) {
      dist[k] = border_dist_[static_cast<std::size_t>(dense_rows_[k])];
      face[k] = R_.dense.face_ids(dense_rows_[k]);
      if (dense_overhangs(H, dense_rows_[k], y, e, j, s)) {
        err[k] = kOverhang;
        continue;
      }
    }
    if (j < 0 || !(e <= tol)) continue;
    is_on[k] = nm.dot(T_.dense_normals.row(j)) > 0.5;
  }
  if (!dist.empty()) keep_truncations(err, face, dist, tol, tol * 10);
  int on = 0, over = 0;
  double sq_over = 0;
  for (std::size_t k = 0; k < err.size(); ++k) {
    on += is_on[k];
    if (err[k] == kOverhang) {
      ++over;
      sq_over += e2[k];
    }
  }
  // Samples that run past the end of the target's surface are left out of the score and the RMS
  // while they are at most max_overhang of the reference (else they count as off the target).
  const std::size_t n = std::max<std::size_t>(1, dense_rows_.size());
  ev.overhang = static_cast<double>(over) / static_cast<double>(n);
  const bool skip = over > 0 && ev.overhang <= p_.max_overhang;
  const double kept = static_cast<double>(std::max<std::size_t>(1, n - (skip ? static_cast<std::size_t>(over) : 0)));
  ev.rms = std::sqrt((sq - (skip ? sq_over : 0.0)) / kept);
  ev.score = static_cast<double>(on) / kept;
  // Key point agreement (paper's shape index, used as a check): the reference key points must land
  // near target key points of a similar shape index, not on plain or differently curved surface.
  int agree = 0;
  std::vector<int> near_keys;
  std::vector<float> near_d2;
  const bool turns = turns_freely(H);
  for (const Eigen::Index i : core_keys_) agree += key_agrees(H, i, tol + T_.sparse_h, s, turns, near_keys, near_d2) ? 1 : 0;
  ev.key_agreement = static_cast<double>(agree) / static_cast<double>(std::max<std::size_t>(1, core_keys_.size()));
  ev.deformation = deformation(H, rlo_, rhi_);

  ev.checks.push_back({"finite", finite_map ? 1.0 : 0.0, 1.0, finite_map});
  ev.checks.push_back({"accept_error", ev.error, p_.accept_error * L_, ev.error <= p_.accept_error * L_});
  ev.checks.push_back({"min_score", ev.score, p_.min_score, ev.score >= p_.min_score});
  if (over > 0) ev.checks.push_back({"max_overhang", ev.overhang, p_.max_overhang, ev.overhang <= p_.max_overhang});
  ev.checks.push_back({"min_key_agreement", ev.key_agreement, p_.min_key_agreement, ev.key_agreement >= p_.min_key_agreement});
  // Free space in front of the reference (clearance.h), then whole faces on whole faces.
  if ((ev.accepted() || all) && p_.max_obstructed < 1) {
    ev.obstructed = clearance_->obstructed(H, [this](const Eigen::Vector3d& y) { return target_distance(y); }, 0.5 * s * R_.dense_h + T_.dense_h,
                                           3 * R_.dense_h + 2 * ev.error);
    ev.checks.push_back({"max_obstructed", ev.obstructed, p_.max_obstructed, ev.obstructed <= p_.max_obstructed});
  }
  if ((ev.accepted() || all) && whole_faces_.reference) {
    ev.partial_faces = whole_faces_.partial_share(H, tol + T_.dense_h, kWholeFaceFill);
    ev.checks.push_back({"max_partial_faces", ev.partial_faces, p_.max_partial_faces, ev.partial_faces <= p_.max_partial_faces});
  }
  if ((ev.accepted() || all) && through_ends_.rows() > 0) {
    ev.partial_faces = std::max(ev.partial_faces, through_share(H, tol));
    ev.checks.push_back({"max_partial_faces", ev.partial_faces, p_.max_partial_faces, ev.partial_faces <= p_.max_partial_faces});
  }
  return ev;
}

}  // namespace fe
