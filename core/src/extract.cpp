// The pipeline of Takashima & Kanai, section 3: describe() is steps 1-3, match() steps 4-6.
#include "featureextract/extract.h"

#include "featureextract/clearance.h"
#include "featureextract/geometry.h"
#include "featureextract/reference.h"
#include "kdtree.h"
#include "pairing.h"
#include "shot.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <numeric>
#include <random>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <sstream>
#include <unordered_map>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace fe {

struct ShapeDescription::Impl {
  Role role = Role::Target;
  double L = 0;          // feature size (reference diagonal)
  Params params;
  double dense_h = 0, sparse_h = 0;
  Samples dense;
  Points dense_normals;  // PCA normals of the dense samples
  std::shared_ptr<KdTree3> dense_tree;
  Points sparse_points;
  Points keys, key_normals;
  Eigen::VectorXd key_si;
  ShotSet shot;
  int m = 0, D = 0, U = 0;  // radii per descriptor; target ladder steps below / above
  Eigen::Vector3d box_min, box_max;
  ShapeStats stats;
  std::vector<std::pair<std::string, double>> timings;
  std::vector<std::string> warnings;
};

ShapeStats ShapeDescription::stats() const { return impl_ ? impl_->stats : ShapeStats{}; }
double ShapeDescription::feature_size() const { return impl_ ? impl_->L : 0.0; }
ShapeDescription::Role ShapeDescription::role() const { return impl_ ? impl_->role : Role::Target; }
std::vector<std::pair<std::string, double>> ShapeDescription::timings() const { return impl_ ? impl_->timings : decltype(impl_->timings){}; }
const Points& ShapeDescription::dense_points() const { return impl_->dense.points; }
const Points& ShapeDescription::sparse_points() const { return impl_->sparse_points; }
const Points& ShapeDescription::key_points() const { return impl_->keys; }
const Eigen::VectorXd& ShapeDescription::key_shape_index() const { return impl_->key_si; }
std::vector<std::string> ShapeDescription::warnings() const { return impl_ ? impl_->warnings : std::vector<std::string>{}; }

namespace {

using Clock = std::chrono::steady_clock;

struct Stopwatch {
  Clock::time_point t0 = Clock::now();
  double lap() {
    const auto t = Clock::now();
    const double s = std::chrono::duration<double>(t - t0).count();
    t0 = t;
    return s;
  }
};

void report(const ProgressFn& progress, const std::string& stage, double f) {
  if (progress && !progress(stage, std::min(1.0, std::max(0.0, f)))) throw Cancelled();
}

void set_threads(const Params& p) {
#ifdef _OPENMP
  omp_set_num_threads(p.threads > 0 ? p.threads : omp_get_num_procs());
#endif
}

double mesh_area(const TriangleMesh& m) {
  double a = 0;
  for (Eigen::Index t = 0; t < m.triangles.rows(); ++t) {
    const Eigen::Vector3d p = m.vertices.row(m.triangles(t, 0)), q = m.vertices.row(m.triangles(t, 1)),
                          r = m.vertices.row(m.triangles(t, 2));
    a += 0.5 * (q - p).cross(r - p).norm();
  }
  return a;
}

int ladder_steps(double scale, double ratio) {
  return std::max(0, static_cast<int>(std::ceil(std::log(scale) / std::log(ratio) - 1e-9)));
}

// The reference has too few of the paper's key points (with_fallback tries ridge and rut points).
struct NoKeyPoints : InputError {
  using InputError::InputError;
};

// The parameters that shape a description (steps 1-3) besides the feature size, the seed and (for a
// target) the scale range: match() requires them equal, and they key PreparedTarget's cache.
std::vector<std::pair<const char*, double>> descriptor_parameters(const Params& p) {
  return {{"dense_spacing", p.dense_spacing},         {"sparse_spacing", p.sparse_spacing},
          {"max_dense_points", static_cast<double>(p.max_dense_points)},
          {"normal_radius", p.normal_radius},         {"curvature_radius", p.curvature_radius},
          {"planar_curvedness", p.planar_curvedness}, {"shot_radius", p.shot_radius},
          {"shot_radii", p.shot_radii},               {"shot_radius_ratio", p.shot_radius_ratio},
          {"si_band", p.si_band},                     {"ridge_rut_spacing", p.ridge_rut_spacing},
          {"crease_key_points", p.crease_key_points ? 1.0 : 0.0}};
}

}  // namespace

ShapeDescription describe(const TriangleMesh& mesh, ShapeDescription::Role role, double L, const Params& p,
                          const ProgressFn& progress) {
  p.validate();
  set_threads(p);
  if (!(L > 0) || !std::isfinite(L)) throw std::invalid_argument("describe: feature size must be > 0");
  auto d = std::make_shared<ShapeDescription::Impl>();
  d->role = role;
  d->L = L;
  d->params = p;
  const bool is_ref = role == ShapeDescription::Role::Reference;
  const std::string who = is_ref ? "reference" : "target";
  const std::string& name = mesh.source.empty() ? who : mesh.source;
  Stopwatch sw;

  // Step 1: dense and sparse samples.
  report(progress, who + ": sampling", 0);
  d->dense_h = p.dense_spacing * L;
  d->sparse_h = p.sparse_spacing * L;
  const double area = mesh_area(mesh);
  const double expected = area / (d->dense_h * d->dense_h);
  if (expected > static_cast<double>(p.max_dense_points)) {
    const double f = std::sqrt(expected / static_cast<double>(p.max_dense_points));
    if (f > 10) {
      // Samples 10x coarser than the feature needs cannot show it: refuse instead of working long for
      // nothing (a 10 mm boss on a 4 m part, or coordinates corrupted along one axis).
      std::ostringstream m;
      m.precision(3);
      m << name << ": the surface is too large for a feature of this size (area " << area << ", " << area / (L * L)
        << " times the feature's squared size): the samples would be " << f
        << "x coarser than the feature needs; search a region of the part, or raise max_dense_points";
      throw InputError(m.str());
    }
    d->dense_h *= f;
    d->sparse_h = std::max(d->sparse_h, 2.5 * d->dense_h);
    std::ostringstream w;
    w << name << ": surface too large for the dense spacing (" << static_cast<long long>(expected)
      << " samples > max_dense_points); spacing increased " << f << "x, small features may be missed";
    d->warnings.push_back(w.str());
  }
  d->dense = sample_surface(mesh, d->dense_h, p.seed);
  const Samples sparse = sample_surface(mesh, d->sparse_h, p.seed + 1);
  d->box_min = mesh.vertices.colwise().minCoeff();
  d->box_max = mesh.vertices.colwise().maxCoeff();
  d->timings.push_back({who + "_sampling", sw.lap()});

  // Step 2a: normals (PCA over dense samples, oriented by the triangles).
  report(progress, who + ": normals", 0);
  const double rn = p.normal_radius * L;
  d->dense_normals = estimate_normals(d->dense, d->dense, rn);
  const Points sparse_normals = estimate_normals(d->dense, sparse, rn);
  d->timings.push_back({who + "_normals", sw.lap()});

  // Step 2b + 3: shape index at sparse samples, key points.
  report(progress, who + ": shape index", 0);
  const Eigen::MatrixX2d k = principal_curvatures(d->dense.points, d->dense_normals, sparse.points, sparse_normals, p.curvature_radius * L);
  std::vector<Eigen::Index> key;
  std::vector<double> key_si;
  // Ridge and rut points (cylinders: holes, lugs, bosses, fillets) are not key points in the paper;
  // with ridge_rut_spacing > 0 they are kept too, thinned to one per cube of that size, so that
  // features made of cylinders still have key points without flooding the matching.
  std::unordered_map<std::uint64_t, char> ridge_cells;
  const double ridge_h = p.ridge_rut_spacing * L;
  const Eigen::Vector3d origin = sparse.points.size() ? Eigen::Vector3d(sparse.points.colwise().minCoeff()) : Eigen::Vector3d::Zero();
  // Sharp creases (machined features: planes meeting at edges and corners) look planar to the quadric
  // fit over same-side neighbours; there the crease's own shape index is used, offset so that sharp
  // and filleted shapes stay apart (kCreaseShapeIndex).
  const Eigen::VectorXd crease = p.crease_key_points ? crease_shape_index(d->dense, sparse, p.curvature_radius * L)
                                                     : Eigen::VectorXd::Constant(k.rows(), std::numeric_limits<double>::quiet_NaN());
  for (Eigen::Index i = 0; i < k.rows(); ++i) {
    double si = shape_index(k(i, 0), k(i, 1), p.planar_curvedness / L);
    if ((si == kPlanarShapeIndex || !std::isfinite(si)) && std::isfinite(crease(i))) si = kCreaseShapeIndex + crease(i);
    bool take = is_key_shape_index(si, p.si_band);
    if (!take && ridge_h > 0 && si >= 0) {
      const Eigen::Vector3d g = ((sparse.points.row(i).transpose() - origin) / ridge_h).array().floor();
      const std::uint64_t cell = (static_cast<std::uint64_t>(g.x()) & 0x1FFFFF) << 42 |
                                 (static_cast<std::uint64_t>(g.y()) & 0x1FFFFF) << 21 | (static_cast<std::uint64_t>(g.z()) & 0x1FFFFF);
      take = ridge_cells.emplace(cell, 1).second;
    }
    if (take) {
      key.push_back(i);
      key_si.push_back(si);
    }
  }
  d->timings.push_back({who + "_shape_index", sw.lap()});

  // Step 2c: multi-radius SHOT at key points, dense samples as support.
  d->m = p.shot_radii;
  if (!is_ref) {
    d->D = ladder_steps(1.0 / p.scale_min, p.shot_radius_ratio);
    d->U = ladder_steps(p.scale_max, p.shot_radius_ratio);
  }
  std::vector<double> radii;
  for (int r = -d->D; r < d->m + d->U; ++r) radii.push_back(p.shot_radius * L * std::pow(p.shot_radius_ratio, r));
  Points keys(static_cast<Eigen::Index>(key.size()), 3), key_n(static_cast<Eigen::Index>(key.size()), 3);
  for (std::size_t i = 0; i < key.size(); ++i) {
    keys.row(static_cast<Eigen::Index>(i)) = sparse.points.row(key[i]);
    key_n.row(static_cast<Eigen::Index>(i)) = sparse_normals.row(key[i]);
  }
  report(progress, who + ": SHOT descriptors", 0);
  ShotSet shot = compute_shot(keys, key_n, d->dense.points, d->dense_normals, d->dense_h, radii, p.threads, [&](std::size_t r) {
    return !progress || progress(who + ": SHOT descriptors", static_cast<double>(r + 1) / static_cast<double>(radii.size()));
  });
  // Drop key points without any finite descriptor (paper: non-finite descriptors are not matched).
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < keys.rows(); ++i)
    if (shot.valid.row(i).any()) keep.push_back(i);
  d->keys.resize(static_cast<Eigen::Index>(keep.size()), 3);
  d->key_normals.resize(static_cast<Eigen::Index>(keep.size()), 3);
  d->key_si.resize(static_cast<Eigen::Index>(keep.size()));
  d->shot.desc.resize(static_cast<Eigen::Index>(keep.size()), shot.desc.cols());
  d->shot.valid.resize(static_cast<Eigen::Index>(keep.size()), shot.valid.cols());
  d->shot.lrf.resize(static_cast<Eigen::Index>(keep.size()), shot.lrf.cols());
  for (std::size_t a = 0; a < keep.size(); ++a) {
    const Eigen::Index i = keep[a], r = static_cast<Eigen::Index>(a);
    d->keys.row(r) = keys.row(i);
    d->key_normals.row(r) = key_n.row(i);
    d->key_si(r) = key_si[static_cast<std::size_t>(i)];
    d->shot.desc.row(r) = shot.desc.row(i);
    d->shot.valid.row(r) = shot.valid.row(i);
    d->shot.lrf.row(r) = shot.lrf.row(i);
  }
  d->timings.push_back({who + "_shot", sw.lap()});
  d->dense_tree = std::make_shared<KdTree3>(d->dense.points);
  d->sparse_points = sparse.points;

  ShapeStats& s = d->stats;
  s.triangles = static_cast<std::size_t>(mesh.triangles.rows());
  s.faces = static_cast<std::size_t>(mesh.num_faces);
  s.dense_points = d->dense.size();
  s.sparse_points = sparse.size();
  s.key_points = key.size();
  s.descriptors = keep.size();
  s.dropped_degenerate = mesh.dropped_degenerate;
  s.diagonal = mesh.diagonal();

  if (is_ref) {
    int full = 0;
    for (Eigen::Index i = 0; i < d->shot.valid.rows(); ++i) full += d->shot.valid.row(i).head(d->m).all() ? 1 : 0;
    if (full < 5) {
      std::ostringstream e;
      e << name << ": reference has no distinctive key points (" << full << " with descriptors, need 5)";
      if (p.ridge_rut_spacing > 0)
        e << ", not even on ridges and ruts: it is one plane, or too small for the sampling";
      else
        e << ": it is planar, or only ridges and ruts; pick a feature with corners, caps or saddles";
      throw NoKeyPoints(e.str());
    }
  }
  return ShapeDescription(d);
}

namespace {

// Distance from p to the sampled surface: point-to-plane at the nearest dense sample, with the
// tangential offset beyond one sample spacing added back (so points off the edge of a surface count).
// That distance measured at dense sample j, which lies d2 (squared) from p.
double distance_at_sample(const ShapeDescription::Impl& t, const Eigen::Vector3d& p, int j, double d2) {
  const Eigen::Vector3d q = t.dense.points.row(j), n = t.dense_normals.row(j);
  const double dn = std::abs((p - q).dot(n));
  const double dt = std::sqrt(std::max(0.0, d2 - dn * dn));
  const double over = std::max(0.0, dt - t.dense_h);
  return std::sqrt(dn * dn + over * over);
}

double surface_distance(const ShapeDescription::Impl& t, const Eigen::Vector3d& p, int* nearest = nullptr) {
  double d2;
  const int j = t.dense_tree->nearest(p, &d2);
  if (nearest) *nearest = j;
  if (j < 0 || !std::isfinite(d2)) return INFINITY;
  return distance_at_sample(t, p, j, d2);
}

// surface_distance where only values below `cap` matter (errors truncated at a penalty): the same
// value and nearest sample whenever the distance is below cap; cap itself, with *nearest = -1, when no
// sample lies near enough for it to be (the tangential offset counts only beyond one spacing h, so the
// distance is at least the nearest sample's minus h). Far points stop the tree search early.
double surface_distance_capped(const ShapeDescription::Impl& t, const Eigen::Vector3d& p, double cap, int* nearest) {
  *nearest = -1;
  if (!p.allFinite() || t.dense_tree->size() == 0) return INFINITY;
  double d2;
  const int j = t.dense_tree->nearest_within(p, 1.01 * (cap + t.dense_h), &d2);
  if (j < 0) return cap;
  *nearest = j;
  return distance_at_sample(t, p, j, d2);
}

// Axisymmetry of the reference (issue 5): on a surface of revolution every normal line meets the
// axis, so the Pluecker coordinates (n, x x n) of all normal lines satisfy one linear equation
// a.(x x n) + m.n = 0 with (a, m) the axis line. The smallest singular vector of that system gives
// the axis; its residual (a distance) says how well it holds. Planes alone (all normals parallel)
// are excluded: some normals must turn around the axis.
struct Symmetry {
  bool axisymmetric = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero(), axis = Eigen::Vector3d::UnitZ();
  double residual = INFINITY;  // RMS distance of the normal lines from the axis, in model units
};
Symmetry detect_axisymmetry(const Points& x, const Points& n, double L) {
  Symmetry sym;
  if (x.rows() < 20) return sym;
  const Eigen::Vector3d c = x.colwise().mean().transpose();
  Eigen::Matrix<double, 6, 6> M = Eigen::Matrix<double, 6, 6>::Zero();
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    const Eigen::Vector3d xi = (x.row(i).transpose() - c) / L, ni = n.row(i).transpose();
    Eigen::Matrix<double, 6, 1> r;
    r << xi.cross(ni), ni;
    M += r * r.transpose();
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(M);
  const Eigen::Matrix<double, 6, 1> v = es.eigenvectors().col(0);
  const Eigen::Vector3d a = v.head<3>(), m = v.tail<3>();
  if (a.norm() < 1e-6) return sym;
  // the line {p : p x a = m'} with moment m' = -m (sign of the equation above), normalized
  const Eigen::Vector3d dir = a.normalized();
  const Eigen::Vector3d moment = -m / a.norm();
  sym.axis = dir;
  sym.point = c + L * dir.cross(moment);  // closest point of the axis to the centroid
  // The algebraic fit weighs rows by their moment; refine the axis point geometrically: each normal
  // line lies in a plane with the axis, so (x - p).(a x n) = 0; rows normalized, trimmed twice.
  std::vector<double> res(static_cast<std::size_t>(x.rows()));
  for (int pass = 0; pass < 3; ++pass) {
    const Eigen::Vector3d u0 = dir.unitOrthogonal(), w0 = dir.cross(u0);
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
      const Eigen::Vector3d k = dir.cross(n.row(i).transpose());
      res[static_cast<std::size_t>(i)] = k.norm() > 0.2 ? std::abs((x.row(i).transpose() - sym.point).dot(k.normalized())) : -1;
    }
    std::vector<double> valid;
    for (double r : res) if (r >= 0) valid.push_back(r);
    if (valid.size() < 10) return sym;
    std::nth_element(valid.begin(), valid.begin() + static_cast<long>(valid.size() * 8 / 10), valid.end());
    const double cut = std::max(valid[valid.size() * 8 / 10], 1e-9 * L);
    Eigen::Matrix2d N = Eigen::Matrix2d::Zero();
    Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
    for (Eigen::Index i = 0; i < x.rows(); ++i) {
      if (res[static_cast<std::size_t>(i)] < 0 || res[static_cast<std::size_t>(i)] > cut) continue;
      const Eigen::Vector3d k = dir.cross(n.row(i).transpose()).normalized();
      const Eigen::Vector2d row(k.dot(u0), k.dot(w0));  // k is orthogonal to dir: p moves in the plane
      N += row * row.transpose();
      rhs += row * (x.row(i).transpose() - sym.point).dot(k);
    }
    if (std::abs(N.determinant()) < 1e-12) return sym;
    const Eigen::Vector2d dp = N.ldlt().solve(rhs);
    sym.point += dp(0) * u0 + dp(1) * w0;
  }
  std::vector<double> dist;  // distances of the normal lines' planes from the final axis
  for (Eigen::Index i = 0; i < x.rows(); ++i) {
    const Eigen::Vector3d k = dir.cross(n.row(i).transpose());
    if (k.norm() > 0.2) dist.push_back(std::abs((x.row(i).transpose() - sym.point).dot(k.normalized())));
  }
  if (dist.empty()) return sym;
  std::nth_element(dist.begin(), dist.begin() + static_cast<long>(dist.size() / 2), dist.end());
  sym.residual = dist[dist.size() / 2];
  // normals must spread around the axis (not a single plane, not a single cylinder direction only)
  Eigen::Matrix2d spread = Eigen::Matrix2d::Zero();
  const Eigen::Vector3d u = dir.unitOrthogonal(), w = dir.cross(u);
  for (Eigen::Index i = 0; i < n.rows(); ++i) {
    const Eigen::Vector2d q(n.row(i).dot(u), n.row(i).dot(w));
    spread += q * q.transpose();
  }
  spread /= static_cast<double>(n.rows());
  const double lo = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(spread).eigenvalues()(0);
  sym.axisymmetric = sym.residual < 0.004 * L && lo > 0.05;
  return sym;
}


// For an axisymmetric reference the rotation about its axis is free: choose the one that makes the
// linear part of H twist least (maximal trace of A R), so that instances come out without an
// arbitrary spin and the same input always gives the same mesh orientation.
Eigen::Matrix4d untwist(const Eigen::Matrix4d& H, const Symmetry& sym) {
  const Eigen::Matrix3d A = transform_jacobian(H, sym.point);
  const Eigen::Vector3d a = sym.axis;
  Eigen::Matrix3d K;
  K << 0, -a.z(), a.y(), a.z(), 0, -a.x(), -a.y(), a.x(), 0;
  const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - a * a.transpose();
  const double theta = std::atan2((A * K).trace(), (A * P).trace());
  const Eigen::Matrix3d R = Eigen::AngleAxisd(theta, a).toRotationMatrix();
  Eigen::Matrix4d G = Eigen::Matrix4d::Identity();
  G.topLeftCorner<3, 3>() = R;
  G.topRightCorner<3, 1>() = sym.point - R * sym.point;
  Eigen::Matrix4d out = H * G;
  return out / out(3, 3);
}

// Axisymmetric references: RANSAC pairs contradict each other (any spin about the axis is as good),
// and a general projective fit can drift into a skewed map of a boss. This fit uses the symmetric
// model instead: the target's own axis (found the same way as the reference's, on the target samples
// around the current fit), then radial scale, axial scale and axial offset by point-to-plane least
// squares, a few ICP rounds. Returns H unchanged when the target axis cannot be found.
Eigen::Matrix4d fit_axisymmetric(const Eigen::Matrix4d& H, const Symmetry& rs, const Points& ref_pts, const Points& ref_nrm,
                                 const ShapeDescription::Impl& T, double size) {
  Points mapped(ref_pts.rows(), 3);
  for (Eigen::Index i = 0; i < ref_pts.rows(); ++i) mapped.row(i) = apply_transform(H, ref_pts.row(i).transpose());
  if (!mapped.allFinite()) return H;
  const Eigen::Vector3d lo = mapped.colwise().minCoeff().transpose() - Eigen::Vector3d::Constant(0.05 * size);
  const Eigen::Vector3d hi = mapped.colwise().maxCoeff().transpose() + Eigen::Vector3d::Constant(0.05 * size);
  std::vector<Eigen::Index> near;
  for (Eigen::Index j = 0; j < T.dense.points.rows(); ++j) {
    const Eigen::Vector3d q = T.dense.points.row(j);
    if ((q.array() >= lo.array()).all() && (q.array() <= hi.array()).all()) near.push_back(j);
  }
  if (near.size() < 50) return H;
  Points tp(static_cast<Eigen::Index>(near.size()), 3), tn(static_cast<Eigen::Index>(near.size()), 3);
  for (std::size_t k = 0; k < near.size(); ++k) {
    tp.row(static_cast<Eigen::Index>(k)) = T.dense.points.row(near[k]);
    tn.row(static_cast<Eigen::Index>(k)) = T.dense_normals.row(near[k]);
  }
  const Symmetry ts = detect_axisymmetry(tp, tn, size);
  if (std::getenv("FE_DEBUG")) std::fprintf(stderr, "debug: target axis residual %.4f (size %.2f) point %.2f %.2f %.2f dir %.3f %.3f %.3f\n", ts.residual, size, ts.point.x(), ts.point.y(), ts.point.z(), ts.axis.x(), ts.axis.y(), ts.axis.z());
  if (!(ts.residual < 0.01 * size)) return H;
  const Eigen::Vector3d ar = rs.axis, cr = rs.point;
  Eigen::Vector3d at = ts.axis;
  if ((transform_jacobian(H, cr) * ar).dot(at) < 0) at = -at;
  const Eigen::Matrix3d R = Eigen::Quaterniond::FromTwoVectors(ar, at).toRotationMatrix();
  // initial parameters from H
  const double s0 = std::cbrt(std::abs(transform_jacobian(H, cr).determinant()));
  double sr = s0, sa = s0, t = (apply_transform(H, cr) - ts.point).dot(at);
  auto model = [&](double r_, double a_, double t_) {
    Eigen::Matrix4d M = Eigen::Matrix4d::Identity();
    const Eigen::Matrix3d lin = r_ * R * (Eigen::Matrix3d::Identity() - ar * ar.transpose()) + a_ * at * ar.transpose();
    M.topLeftCorner<3, 3>() = lin;
    M.topRightCorner<3, 1>() = ts.point + t_ * at - lin * cr;
    return M;
  };
  for (int iter = 0; iter < 10; ++iter) {
    const Eigen::Matrix4d M = model(sr, sa, t);
    std::vector<Eigen::Vector4d> rows;  // (d sr, d sa, d t | rhs)
    std::vector<double> err;
    for (Eigen::Index i = 0; i < ref_pts.rows(); ++i) {
      const Eigen::Vector3d x = ref_pts.row(i), d = x - cr;
      const double h = d.dot(ar);
      const Eigen::Vector3d rho = R * (d - h * ar);
      const Eigen::Vector3d y = apply_transform(M, x);
      const Eigen::Vector3d ny = (M.topLeftCorner<3, 3>().inverse().transpose() * ref_nrm.row(i).transpose()).normalized();
      double d2;
      const int j = T.dense_tree->nearest(y, &d2);
      if (j < 0 || ny.dot(T.dense_normals.row(j)) < 0.5) continue;
      const Eigen::Vector3d q = T.dense.points.row(j), n = T.dense_normals.row(j);
      rows.emplace_back(rho.dot(n), h * at.dot(n), at.dot(n), (q - ts.point).dot(n));
      err.push_back(std::sqrt(d2));
    }
    if (rows.size() < 30) return H;
    std::vector<double> sorted = err;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
    const double cut = std::max(3.0 * sorted[sorted.size() / 2], 1e-3 * size);
    Eigen::Matrix3d N = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < rows.size(); ++k) {
      if (err[k] > cut) continue;
      const Eigen::Vector3d g = rows[k].head<3>();
      N += g * g.transpose();
      b += g * rows[k](3);
    }
    const Eigen::Vector3d sol = N.ldlt().solve(b);
    if (!sol.allFinite() || sol(0) <= 0 || sol(1) <= 0) return H;
    const bool done = std::abs(sol(0) - sr) < 1e-6 * s0 && std::abs(sol(1) - sa) < 1e-6 * s0 && std::abs(sol(2) - t) < 1e-6 * size;
    sr = sol(0);
    sa = sol(1);
    t = sol(2);
    if (done) break;
  }
  if (std::getenv("FE_DEBUG")) std::fprintf(stderr, "debug: axisymmetric fit sr %.3f sa %.3f t %.3f\n", sr, sa, t);
  return model(sr, sa, t);
}


struct Instance {
  Match match;
  std::vector<int> covered;  // target dense samples covered, sorted
};

// Stable order for the user: by position (x, then y, then z), then score (a strict weak order).
void sort_matches(std::vector<Match>& m) {
  std::sort(m.begin(), m.end(), [](const Match& a, const Match& b) {
    for (int i = 0; i < 3; ++i)
      if (a.center[i] != b.center[i]) return a.center[i] < b.center[i];
    return a.score > b.score;
  });
}

// Deterministic subsample of at most n row indices.
std::vector<Eigen::Index> stride_rows(Eigen::Index rows, Eigen::Index n) {
  std::vector<Eigen::Index> r;
  const double step = std::max(1.0, static_cast<double>(rows) / static_cast<double>(n));
  for (double x = 0; x < static_cast<double>(rows); x += step) r.push_back(static_cast<Eigen::Index>(x));
  return r;
}

// The part of a box-cut reference that is feature (issue 9): a user's box takes some of the part
// around the feature too, and that context need not be the same around every instance (FTC-10's
// ears: 4 of 4 found with a tight box, 2 of 4 with a box 20 % larger). Samples within `margin` of
// the extent of a cut side of the box are context: hypotheses are judged, refined and validated on
// the rest (the core). Not set: everything is feature (picked faces, an open STL region).
struct FeatureCore {
  bool set = false;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(-INFINITY), hi = Eigen::Vector3d::Constant(INFINITY);
  bool contains(const Eigen::Vector3d& x) const { return (x.array() >= lo.array()).all() && (x.array() <= hi.array()).all(); }
};
constexpr double kContextMargin = 0.2;
// A target face covered less than this by the mapped reference is only partly the feature's
// (whole_faces): a step on 40 % of a slot's floor; a boss of other proportions covers 70 %.
constexpr double kWholeFaceFill = 0.6;

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
  // The SHOT local frames of a pair at the middle radius (the target's shifted by the pair's scale):
  // t_frame(pr)^T r_frame(pr) rotates reference directions into the target.
  const int mid = R.m / 2;
  auto r_frame = [&](const KeyPointPair& pr) { return R.shot.frame(pr.ref, mid); };
  auto t_frame = [&](const KeyPointPair& pr) { return T.shot.frame(pr.tgt, pr.shift + T.D + mid); };
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
        const Eigen::Matrix3d rot = t_frame(cp[i]).transpose() * r_frame(cp[i]);
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

  // Step 6: RANSAC per cluster, repeated to take every instance a cluster holds.
  // Rows of the reference's key points and dense samples that are feature (see FeatureCore), and
  // a deterministic subsample of at most n of them.
  auto core_rows = [&](const Points& x) {
    std::vector<Eigen::Index> r;
    for (Eigen::Index i = 0; i < x.rows(); ++i)
      if (core.contains(x.row(i).transpose())) r.push_back(i);
    if (r.size() < 20 || r.size() * 10 < static_cast<std::size_t>(x.rows())) {  // too little left: all is feature
      r.resize(static_cast<std::size_t>(x.rows()));
      std::iota(r.begin(), r.end(), Eigen::Index{0});
    }
    return r;
  };
  const std::vector<Eigen::Index> core_keys = core_rows(R.keys), core_dense = core_rows(R.dense.points);
  if (std::getenv("FE_DEBUG") && core.set)
    std::fprintf(stderr, "debug: feature core (%.1f %.1f %.1f)..(%.1f %.1f %.1f): %zu of %ld key points, %zu of %zu dense samples\n", core.lo.x(), core.lo.y(),
                 core.lo.z(), core.hi.x(), core.hi.y(), core.hi.z(), core_keys.size(), static_cast<long>(R.keys.rows()), core_dense.size(), R.dense.size());
  auto sub_rows = [](const std::vector<Eigen::Index>& rows, Eigen::Index n) {
    std::vector<Eigen::Index> r;
    for (Eigen::Index i : stride_rows(static_cast<Eigen::Index>(rows.size()), n)) r.push_back(rows[static_cast<std::size_t>(i)]);
    return r;
  };
  // Points that judge a transform: the reference key points (paper) plus a fixed subsample of the
  // reference's dense samples, so that a transform must lay the whole feature on the target, not only
  // its corners; each with its normal, which must agree with the target's.
  Points eval_pts, eval_nrm;
  {
    const std::vector<Eigen::Index> kr = sub_rows(core_keys, 300);
    const std::vector<Eigen::Index> dr = sub_rows(core_dense, 300);
    eval_pts.resize(static_cast<Eigen::Index>(kr.size() + dr.size()), 3);
    eval_nrm.resize(eval_pts.rows(), 3);
    Eigen::Index k = 0;
    for (Eigen::Index i : kr) { eval_pts.row(k) = R.keys.row(i); eval_nrm.row(k++) = R.key_normals.row(i); }
    for (Eigen::Index i : dr) { eval_pts.row(k) = R.dense.points.row(i); eval_nrm.row(k++) = R.dense_normals.row(i); }
  }
  const double normal_penalty = 2.0 * p.accept_error * L;
  Points refine_pts, refine_nrm;
  const std::vector<Eigen::Index> refine_rows = sub_rows(core_dense, 800);  // rows of R.dense behind refine_pts
  refine_pts.resize(static_cast<Eigen::Index>(refine_rows.size()), 3);
  refine_nrm.resize(refine_pts.rows(), 3);
  for (std::size_t k = 0; k < refine_rows.size(); ++k) {
    refine_pts.row(static_cast<Eigen::Index>(k)) = R.dense.points.row(refine_rows[k]);
    refine_nrm.row(static_cast<Eigen::Index>(k)) = R.dense_normals.row(refine_rows[k]);
  }
  const std::vector<Eigen::Index> dense_rows = sub_rows(core_dense, 1500);
  const Eigen::Vector3d rlo = R.keys.colwise().minCoeff(), rhi = R.keys.colwise().maxCoeff();
  // RMS distance of the mapped reference (dense subsample) to the target surface, model units: the
  // fit error reported before and after the surface refinement.
  auto rms_on_surface = [&](const Eigen::Matrix4d& H) {
    std::vector<double> e(dense_rows.size());  // on all threads, summed in order
#pragma omp parallel for schedule(static)
    for (std::size_t k = 0; k < dense_rows.size(); ++k) e[k] = surface_distance(T, apply_transform(H, R.dense.points.row(dense_rows[k]).transpose()));
    double sq = 0;
    for (const double ek : e) sq += std::isfinite(ek) ? ek * ek : L * L;
    return std::sqrt(sq / static_cast<double>(std::max<std::size_t>(1, dense_rows.size())));
  };
  const Symmetry sym = detect_axisymmetry(refine_pts, refine_nrm, L);
  if (sym.axisymmetric) {
    res.symmetry = "axisymmetric";
    res.symmetry_point = sym.point;
    res.symmetry_axis = sym.axis;
  }

  auto bounds_ok = [&](const Eigen::Matrix4d& H, double* scale) {
    const Deformation df = deformation(H, rlo, rhi);
    if (!(df.volume_ratio > 0) || !std::isfinite(df.perspective)) return false;
    if (df.reflection && !p.allow_reflection) return false;
    if (df.volume_ratio < p.volume_ratio_min || df.volume_ratio > p.volume_ratio_max) return false;
    if (df.scale_min < p.axis_scale_min || df.scale_max > p.axis_scale_max) return false;
    if (df.scale_max > p.max_anisotropy * df.scale_min) return false;
    if (df.perspective > p.max_perspective) return false;
    if (scale) *scale = std::cbrt(df.volume_ratio);
    return true;
  };
  // Paper 3.8 (4)-(5): map the reference key points, error to the nearest dense target point;
  // the error of H is the maximum (or error_quantile) over them, divided by the scale of H.
  // Error of H at evaluation point i, in reference units (divided by the scale s of H): distance to
  // the target surface, or at least `normal_penalty` where the normals disagree; +inf off the target.
  // With `capped`, errors of normal_penalty or more may come back as normal_penalty (for the sums
  // that truncate there anyway): the same sums, with a search that stops at the penalty.
  auto point_error = [&](const Eigen::Matrix4d& H, Eigen::Index i, double s, bool capped = false) -> double {
    const Eigen::Vector3d x = eval_pts.row(i);
    int j;
    double e;
    if (capped) {
      e = surface_distance_capped(T, apply_transform(H, x), normal_penalty * s, &j) / s;
      if (!std::isfinite(e)) return INFINITY;
      if (j < 0) return normal_penalty;
    } else {
      e = surface_distance(T, apply_transform(H, x), &j) / s;
      if (!std::isfinite(e) || j < 0) return INFINITY;
    }
    if ((transform_jacobian(H, x).inverse().transpose() * eval_nrm.row(i).transpose()).normalized().dot(T.dense_normals.row(j)) < 0.5)
      e = std::max(e, normal_penalty);
    return e;
  };
  auto point_errors = [&](const Eigen::Matrix4d& H, double s, double sum_limit, std::vector<double>& errs, bool capped = false) -> bool {
    if (!std::isfinite(sum_limit) && !omp_in_parallel()) {  // nothing to stop early for: all threads
      errs.assign(static_cast<std::size_t>(eval_pts.rows()), 0.0);
#pragma omp parallel for schedule(static)
      for (Eigen::Index i = 0; i < eval_pts.rows(); ++i) errs[static_cast<std::size_t>(i)] = point_error(H, i, s, capped);
      for (const double e : errs)
        if (!std::isfinite(e)) return false;
      return true;
    }
    errs.clear();
    double sum = 0;
    for (Eigen::Index i = 0; i < eval_pts.rows(); ++i) {
      const double e = point_error(H, i, s, capped);
      if (!std::isfinite(e)) return false;
      errs.push_back(e);
      sum += std::min(e, normal_penalty);
      if (sum > sum_limit) return false;  // cannot beat the best any more
    }
    return true;
  };
  // Selection cost (RANSAC, refinement): mean error truncated at the penalty (MSAC), continuous so
  // that a refinement can see progress where a quantile would sit on the penalty. +inf as soon as it
  // cannot come under `limit` (the best so far, in a search). Safe to call from several threads.
  auto cost = [&](const Eigen::Matrix4d& H, double limit = INFINITY) -> double {
    double s;
    if (!bounds_ok(H, &s)) return INFINITY;
    thread_local std::vector<double> buf;
    if (!point_errors(H, s, std::isfinite(limit) ? limit * static_cast<double>(eval_pts.rows()) : INFINITY, buf, true)) return INFINITY;
    double sum = 0;
    for (double e : buf) sum += std::min(e, normal_penalty);
    return sum / static_cast<double>(buf.size());
  };
  // Screening of one-pair placements: the truncated mean error over 40 of the evaluation points,
  // with the scale estimate s (no bounds test: the refinement may still bring it within them).
  const std::vector<Eigen::Index> screen_rows = stride_rows(eval_pts.rows(), 40);
  auto screen_cost = [&](const Eigen::Matrix4d& H, double s) -> double {
    double sum = 0;
    for (const Eigen::Index i : screen_rows) {
      const double e = point_error(H, i, s, true);
      if (!std::isfinite(e)) return INFINITY;
      sum += std::min(e, normal_penalty);
    }
    return sum / static_cast<double>(std::max<std::size_t>(1, screen_rows.size()));
  };
  // Acceptance error (paper 3.8: the maximum; error_quantile < 1: that quantile).
  auto quantile_error = [&](const Eigen::Matrix4d& H) -> double {
    double s;
    std::vector<double> errs;
    if (!bounds_ok(H, &s) || !point_errors(H, s, INFINITY, errs)) return INFINITY;
    const std::size_t q = std::min(errs.size() - 1, static_cast<std::size_t>(p.error_quantile * static_cast<double>(errs.size())));
    std::nth_element(errs.begin(), errs.begin() + static_cast<long>(q), errs.end());
    return errs[q];
  };

  // Distance from a point to the nearest dense sample of a shape (index in *j when asked).
  auto nearest_distance = [](const KdTree3& tree) {
    return [&tree](const Eigen::Vector3d& y, int* j = nullptr) {
      double d2;
      const int k = tree.nearest(y, &d2);
      if (j) *j = k;
      return k < 0 ? INFINITY : std::sqrt(d2);
    };
  };
  const auto reference_distance = nearest_distance(*R.dense_tree);
  const auto target_distance = nearest_distance(*T.dense_tree);
  // Free space in front of the reference's surface (clearance.h), from its core samples.
  const Clearance clearance(R.dense.points, R.dense_normals, sub_rows(core_dense, 400),
                            [&](const Eigen::Vector3d& x) { return reference_distance(x); }, R.box_min, R.box_max, R.dense_h,
                            p.clearance_margin * L);
  // Whole faces (clearance.h): reference faces all of whose samples are feature, with enough samples
  // to measure their area, must land on whole target faces.
  FaceCoverCheck whole_faces;
  std::vector<int> refine_face;             // reference face of each refine point (reverse pairs, below)
  std::vector<std::vector<int>> face_rows;  // target face -> its dense samples, at most 150 (reverse pairs)
  if (R.dense.face_ids.size() && T.dense.face_ids.size() && p.max_partial_faces < 1) {
    const int nf = std::max(R.dense.face_ids.maxCoeff(), 0) + 1;
    std::vector<int> in_core(static_cast<std::size_t>(nf), 0), all(static_cast<std::size_t>(nf), 0);
    for (Eigen::Index i = 0; i < R.dense.face_ids.size(); ++i) ++all[static_cast<std::size_t>(std::max(R.dense.face_ids(i), 0))];
    for (const Eigen::Index i : core_dense) ++in_core[static_cast<std::size_t>(std::max(R.dense.face_ids(i), 0))];
    whole_faces.checked.assign(static_cast<std::size_t>(nf), 0);
    for (int f = 1; f < nf; ++f) whole_faces.checked[static_cast<std::size_t>(f)] = all[static_cast<std::size_t>(f)] >= 20 && in_core[static_cast<std::size_t>(f)] == all[static_cast<std::size_t>(f)];
    whole_faces.reference = &R.dense;
    whole_faces.rows = core_dense;
    whole_faces.reference_spacing = R.dense_h;
    whole_faces.target_faces = &T.dense.face_ids;
    std::vector<std::vector<int>> on_face(static_cast<std::size_t>(std::max(T.dense.face_ids.maxCoeff(), 0) + 1));
    for (Eigen::Index j = 0; j < T.dense.face_ids.size(); ++j)
      if (T.dense.face_ids(j) > 0) on_face[static_cast<std::size_t>(T.dense.face_ids(j))].push_back(static_cast<int>(j));
    whole_faces.target_area.resize(on_face.size());
    face_rows.resize(on_face.size());
    for (std::size_t g = 0; g < on_face.size(); ++g) {
      whole_faces.target_area[g] = static_cast<double>(on_face[g].size()) * T.dense_h * T.dense_h;
      for (const Eigen::Index k : stride_rows(static_cast<Eigen::Index>(on_face[g].size()), 150)) face_rows[g].push_back(on_face[g][static_cast<std::size_t>(k)]);
    }
    whole_faces.target_nearest = [&](const Eigen::Vector3d& y, double* d) {
      int j;
      *d = target_distance(y, &j);
      return j;
    };
    for (const Eigen::Index i : refine_rows) refine_face.push_back(R.dense.face_ids(i));
  }
  // Reverse pairs for the surface refinement (issue 9): the refinement pulls reference samples onto
  // the target, which a fit on part of a larger instance already satisfies (a rib stretched 2x
  // fitted over half its length, a step smaller than the one it lies on). Target samples of the
  // faces that whole reference faces land on pull the other way, onto the nearest mapped reference
  // sample, so the fit grows to cover those faces, up to 4 times the mapped area. Returns the mean
  // distance of those target samples to the mapped reference (reference units, truncated at the
  // normal penalty), and the pairs when asked.
  const double refine_cell = R.dense_h * R.dense_h * static_cast<double>(core_dense.size()) / static_cast<double>(std::max<Eigen::Index>(1, refine_pts.rows()));
  auto reverse_pairs = [&](const Eigen::Matrix4d& H, double s, std::vector<Eigen::Vector3d>* ra, std::vector<Eigen::Vector3d>* rb) -> double {
    if (refine_face.size() != static_cast<std::size_t>(refine_pts.rows())) return 0;
    std::unordered_map<int, std::vector<int>> on;  // target face -> refine points landing on it
    std::vector<char> wanted(whole_faces.target_area.size(), 0);
    std::vector<Eigen::Vector3d> mapped(refine_face.size());
    const double land = 2 * T.dense_h + 0.01 * L * s;
    for (std::size_t k = 0; k < refine_face.size(); ++k) {
      mapped[k] = apply_transform(H, refine_pts.row(static_cast<Eigen::Index>(k)).transpose());
      int j;
      if (!(target_distance(mapped[k], &j) <= land) || j < 0) continue;
      const int g = T.dense.face_ids(j);
      if (g <= 0 || static_cast<std::size_t>(g) >= wanted.size()) continue;
      on[g].push_back(static_cast<int>(k));
      const int f = refine_face[k];
      if (f > 0 && static_cast<std::size_t>(f) < whole_faces.checked.size() && whole_faces.checked[static_cast<std::size_t>(f)]) wanted[static_cast<std::size_t>(g)] = 1;
    }
    double sum = 0;
    int n = 0;
    for (const auto& [g, ks] : on) {
      if (!wanted[static_cast<std::size_t>(g)]) continue;
      const double mapped_area = static_cast<double>(ks.size()) * refine_cell * s * s;
      if (whole_faces.target_area[static_cast<std::size_t>(g)] > 4 * mapped_area) continue;  // not this feature's face
      for (const int t : face_rows[static_cast<std::size_t>(g)]) {
        const Eigen::Vector3d y = T.dense.points.row(t).transpose();
        double best = INFINITY;
        int bk = -1;
        for (const int k : ks) {
          const double d = (mapped[static_cast<std::size_t>(k)] - y).squaredNorm();
          if (d < best) { best = d; bk = k; }
        }
        sum += std::min(std::sqrt(best) / s, normal_penalty);
        ++n;
        if (ra && bk >= 0) {
          ra->push_back(refine_pts.row(bk).transpose());
          rb->push_back(y);
        }
      }
    }
    return n ? sum / n : 0.0;
  };

  const bool debug = std::getenv("FE_DEBUG") != nullptr;  // trace of every RANSAC outcome on stderr
  const KdTree3 tkey_tree(T.keys);
  std::vector<int> near_keys;
  std::vector<float> near_d2;
  std::vector<Instance> found;
  std::uint64_t run = 0;
  for (std::size_t oi = 0; oi < order.size(); ++oi) {
    std::vector<KeyPointPair> pairs = cluster_pairs[order[oi]];
    int failures = 0;
    // progress: clusters done, and within this one the share of its pairs explained or dropped
    const double initial_pairs = static_cast<double>(std::max<std::size_t>(1, pairs.size()));
    auto ransac_fraction = [&] {
      return (static_cast<double>(oi) + 1.0 - static_cast<double>(pairs.size()) / initial_pairs) / static_cast<double>(order.size());
    };
    while (static_cast<int>(pairs.size()) >= p.min_cluster_pairs && failures < p.max_failures && found.size() < 500) {
      report(progress, "ransac", ransac_fraction());
      Points rp(static_cast<Eigen::Index>(pairs.size()), 3), tp(static_cast<Eigen::Index>(pairs.size()), 3);
      for (std::size_t i = 0; i < pairs.size(); ++i) {
        rp.row(static_cast<Eigen::Index>(i)) = R.keys.row(pairs[i].ref);
        tp.row(static_cast<Eigen::Index>(i)) = T.keys.row(pairs[i].tgt);
      }
      // Rotation of each pair from the SHOT local reference frames at the middle radius compared.
      std::vector<Eigen::Matrix3d> rots(pairs.size());
      for (std::size_t i = 0; i < pairs.size(); ++i) {
        rots[i] = t_frame(pairs[i]).transpose() * r_frame(pairs[i]);
      }
      std::vector<double> scales(pairs.size());
      for (std::size_t i = 0; i < pairs.size(); ++i) scales[i] = std::pow(p.shot_radius_ratio, pairs[i].shift);
      RansacOptions ro;
      ro.rotations = &rots;
      ro.scales = &scales;
      ro.max_iterations = p.ransac_max_iterations;
      ro.patience = p.ransac_patience;
      ro.locality = 1.5 * L;  // times the first pair's scale estimate
      ro.ratio_min = 0.8 * p.axis_scale_min;  // slack for key points that sit a sample spacing off
      ro.ratio_max = 1.25 * p.axis_scale_max;
      ro.seed = p.seed * 1000003ULL + (++run);
      ro.batch = 16;  // scored on both cores, the same result as one at a time
      // Placements from one pair each (issue 9): the pair's local frames give the rotation, its SHOT
      // radius shift the scale. Where few pairs are right (a real part's cluster), a 5-pair sample is
      // rarely all right, one pair often is. SHOT's frame axes can flip sign: the four proper sign
      // changes are tried. The best of these competes with the RANSAC result below.
      Eigen::Matrix4d pose_h = Eigen::Matrix4d::Identity();
      double pose_cost = INFINITY;
      int pose_pair = -1;
      if (p.pose_hypotheses) {
        // screened on a few evaluation points, the best few scored in full
        const Eigen::Vector3d flips[4] = {{1, 1, 1}, {-1, -1, 1}, {-1, 1, -1}, {1, -1, -1}};
        const std::size_t stride = std::max<std::size_t>(1, pairs.size() / 1500);
        // (on all threads: each placement's slot is its own, and they are gathered in order)
        const std::size_t m = (pairs.size() + stride - 1) / stride;
        std::vector<double> q4(4 * m, INFINITY);
        std::vector<Eigen::Matrix4d> h4(4 * m);
#pragma omp parallel for schedule(dynamic, 16)
        for (std::size_t k = 0; k < m; ++k) {
          const std::size_t i = k * stride;
          const Eigen::Matrix3d fr = r_frame(pairs[i]), ft = t_frame(pairs[i]);
          if (!fr.allFinite() || !ft.allFinite()) continue;
          for (int f = 0; f < 4; ++f) {
            const Eigen::Matrix3d lin = scales[i] * ft.transpose() * flips[f].asDiagonal() * fr;
            Eigen::Matrix4d& Hc = h4[4 * k + static_cast<std::size_t>(f)];
            Hc.setIdentity();
            Hc.topLeftCorner<3, 3>() = lin;
            Hc.topRightCorner<3, 1>() = tp.row(static_cast<Eigen::Index>(i)).transpose() - lin * rp.row(static_cast<Eigen::Index>(i)).transpose();
            q4[4 * k + static_cast<std::size_t>(f)] = screen_cost(Hc, scales[i]);
          }
        }
        std::vector<std::pair<double, Eigen::Matrix4d>> screened;
        for (std::size_t k = 0; k < 4 * m; ++k)
          if (std::isfinite(q4[k])) screened.emplace_back(q4[k] + 1e-12 * static_cast<double>((k / 4) * stride), h4[k]);
        const std::size_t keep = std::min<std::size_t>(screened.size(), 24);
        std::partial_sort(screened.begin(), screened.begin() + static_cast<long>(keep), screened.end(),
                          [](const auto& a, const auto& b) { return a.first < b.first; });
        for (std::size_t k = 0; k < keep; ++k) {
          const double c = cost(screened[k].second, pose_cost);
          if (c < pose_cost) { pose_cost = c; pose_h = screened[k].second; }
        }
        if (std::isfinite(pose_cost)) {  // the pair whose target point lies nearest the mapped one
          double best = INFINITY;
          for (std::size_t i = 0; i < pairs.size(); ++i) {
            const double d = (apply_transform(pose_h, rp.row(static_cast<Eigen::Index>(i)).transpose()) - tp.row(static_cast<Eigen::Index>(i)).transpose()).norm();
            if (d < best) { best = d; pose_pair = static_cast<int>(i); }
          }
        }
      }
      // RANSAC on its own (the one-pair placements must not cut its search short)
      RansacResult rr = ransac_projective(rp, tp, std::function<double(const Eigen::Matrix4d&, double)>(cost), ro, [&] { return progress && !progress("ransac", ransac_fraction()); });
      if (progress && !progress("ransac", ransac_fraction())) throw Cancelled();
      if (!rr.found && pose_pair < 0) {
        if (debug) std::fprintf(stderr, "debug: cluster %zu pairs %zu: no transform within bounds (%d iterations)\n", order[oi], pairs.size(), rr.iterations);
        break;
      }
      // Each candidate (RANSAC's, the best one-pair placement) is refitted and refined; the better
      // refined one is judged. A placement from one pair can settle on a part of the feature that the
      // refinement cannot extend, RANSAC's fit on a worse local optimum: neither is always right.
      struct Polished {
        Eigen::Matrix4d H;
        double s = 1, rms_unrefined = 0, cost = INFINITY;
        std::array<int, 5> sample{};
      };
      auto polish = [&](const Eigen::Matrix4d& H0, double cost0) -> Polished {
        Eigen::Matrix4d H = H0;
        double s = 1;
        bounds_ok(H, &s);
        // Least-squares refit on the pairs consistent with H (keeps it only if the error does not grow).
        {
          const double tol = p.accept_error * L * s;
          std::vector<Eigen::Index> in;
          for (Eigen::Index i = 0; i < rp.rows(); ++i)
            if ((apply_transform(H, rp.row(i).transpose()) - tp.row(i).transpose()).norm() <= tol) in.push_back(i);
          if (in.size() >= 6) {
            Points a(static_cast<Eigen::Index>(in.size()), 3), b(static_cast<Eigen::Index>(in.size()), 3);
            for (std::size_t k = 0; k < in.size(); ++k) {
              a.row(static_cast<Eigen::Index>(k)) = rp.row(in[k]);
              b.row(static_cast<Eigen::Index>(k)) = tp.row(in[k]);
            }
            Eigen::Matrix4d H2;
            if (fit_projective(a, b, H2) && cost(H2) <= cost0) {
              H = H2;
              bounds_ok(H, &s);
            }
          }
        }
        // Surface refinement (ICP-like): reference dense samples -> foot points on the target's tangent
        // planes, trimmed, projective least squares (affine if that leaves the bounds); kept while the
        // error decreases, and as a whole only if the RMS fit error did not grow.
        const Eigen::Matrix4d H_unrefined = H;
        const double rms_unrefined = rms_on_surface(H);
        {
          // one refinement from H0; with `grow`, reverse pairs let it grow over whole target faces
          struct Refined {
            Eigen::Matrix4d H;
            double s, cost, reverse_start, reverse;
          };
          auto refine = [&](const Eigen::Matrix4d& H0, double s0, bool grow) -> Refined {
            Eigen::Matrix4d H = H0;
            double s = s0;
            double c0 = cost(H);
            double r0 = grow ? reverse_pairs(H, s, nullptr, nullptr) : 0.0;
            const double r_start = r0;
            const double search_radius = 0.25 * L;
            for (int iter = 0; iter < p.refine_iterations && std::isfinite(c0); ++iter) {
              // foot points on all threads, each in its own slot, gathered in order
              const std::size_t nr = static_cast<std::size_t>(refine_pts.rows());
              std::vector<Eigen::Vector3d> fa(nr), fb(nr);
              std::vector<double> fe(nr, -1.0);  // < 0: no foot point
#pragma omp parallel for schedule(dynamic, 32)
              for (std::size_t k = 0; k < nr; ++k) {
                const Eigen::Vector3d x = refine_pts.row(static_cast<Eigen::Index>(k));
                const Eigen::Vector3d y = apply_transform(H, x);
                // nearest target sample whose normal agrees (so the ends of a shortened rib find its end
                // faces instead of being dropped, and pull the fit out to full length)
                const Eigen::Vector3d nm = (transform_jacobian(H, x).inverse().transpose() * refine_nrm.row(static_cast<Eigen::Index>(k)).transpose()).normalized();
                double d2;
                int j = T.dense_tree->nearest(y, &d2);
                if (j < 0) continue;
                if (nm.dot(T.dense_normals.row(j)) < 0.5) {
                  thread_local std::vector<int> near_idx;
                  thread_local std::vector<float> near_d2;
                  T.dense_tree->radius(y, search_radius * s, near_idx, near_d2);
                  j = -1;
                  d2 = INFINITY;
                  for (std::size_t c = 0; c < near_idx.size(); ++c)
                    if (near_d2[c] < d2 && nm.dot(T.dense_normals.row(near_idx[c])) >= 0.5) { j = near_idx[c]; d2 = near_d2[c]; }
                  if (j < 0) continue;
                }
                const Eigen::Vector3d q = T.dense.points.row(j), n = T.dense_normals.row(j);
                fa[k] = x;
                fb[k] = y - (y - q).dot(n) * n;
                fe[k] = std::sqrt(d2);
              }
              std::vector<Eigen::Vector3d> a, b;
              std::vector<double> e;
              for (std::size_t k = 0; k < nr; ++k)
                if (fe[k] >= 0) {
                  a.push_back(fa[k]);
                  b.push_back(fb[k]);
                  e.push_back(fe[k]);
                }
              if (a.size() < 20) break;
              std::vector<double> sorted = e;
              std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
              const double cut = std::max(3.0 * sorted[sorted.size() / 2], 2.0 * T.dense_h);
              Points A(static_cast<Eigen::Index>(a.size()), 3), B(static_cast<Eigen::Index>(a.size()), 3);
              Eigen::Index n = 0;
              for (std::size_t k = 0; k < a.size(); ++k)
                if (e[k] <= cut) { A.row(n) = a[k]; B.row(n++) = b[k]; }
              std::vector<Eigen::Vector3d> ra, rb;
              if (r0 > 0) reverse_pairs(H, s, &ra, &rb);
              // as much weight as the forward pairs (which hold a planar face in place but let it slide)
              const int copies = ra.empty() ? 0 : std::max<int>(1, static_cast<int>(std::lround(static_cast<double>(n) / static_cast<double>(ra.size()))));
              A.conservativeResize(n + copies * static_cast<Eigen::Index>(ra.size()), 3);
              B.conservativeResize(A.rows(), 3);
              for (int c = 0; c < copies; ++c)
                for (std::size_t k = 0; k < ra.size(); ++k) {
                  A.row(n) = ra[k].transpose();
                  B.row(n++) = rb[k].transpose();
                }
              Eigen::Matrix4d H2;
              bool ok = n >= 20 && fit_projective(A, B, H2) && bounds_ok(H2, nullptr);
              if (!ok) ok = n >= 20 && fit_affine(A, B, H2) && bounds_ok(H2, nullptr);
              if (!ok) break;
              const double c1 = cost(H2);
              double s2 = s;
              bounds_ok(H2, &s2);
              const double r1 = r0 > 0 ? reverse_pairs(H2, s2, nullptr, nullptr) : 0.0;
              if (!(c1 + r1 < c0 + r0)) break;
              H = H2;
              if (grow) s = s2;
              c0 = c1;
              r0 = r1;
            }
            return {H, s, c0, r_start, r0};
          };
          const Refined tight = refine(H, s, false);
          Refined chosen_fit = tight;
          if (!refine_face.empty()) {
            // grown over whole faces: kept if its acceptance error stays within 0.4 of the bound (FTC-10's
            // far ear grew from 0.045 to 0.061 L), or near the tight fit's
            const Refined grown = refine(H, s, true);
            if (grown.reverse < 0.8 * grown.reverse_start) {
              const double eg = quantile_error(grown.H), et = quantile_error(tight.H);
              if (debug) std::fprintf(stderr, "   grown: error/L %.4f (tight %.4f), reverse %.4f -> %.4f\n", eg / L, et / L, grown.reverse_start, grown.reverse);
              if (eg <= std::max(1.1 * et, 0.4 * p.accept_error * L)) chosen_fit = grown;
            }
          }
          H = chosen_fit.H;
          s = chosen_fit.s;
          const bool grew = chosen_fit.reverse < 0.8 * chosen_fit.reverse_start;
          double rh = rms_on_surface(H);  // RMS of the current H, kept up to date below
          // (a fit grown over whole faces lies a little less tightly on them: its error was checked)
          if (!grew && rh > rms_unrefined) {
            H = H_unrefined;
            rh = rms_unrefined;
          }
          if (sym.axisymmetric) {
            // The symmetric model fit, preferred unless clearly worse: a general projective map can
            // lower the RMS a little by skewing a boss, which the symmetric model (3 parameters on the
            // target's own axis) cannot.
            bounds_ok(H, &s);
            const Eigen::Matrix4d Ha = fit_axisymmetric(H, sym, refine_pts, refine_nrm, T, L * s);
            if (!Ha.isApprox(H) && bounds_ok(Ha, nullptr)) {
              const double ra = rms_on_surface(Ha);
              if (ra <= std::max(1.25 * rh, rh + 0.002 * L * s)) {
                H = Ha;
                rh = ra;
              }
            }
            // the free spin about the axis: the least twisted one
            const Eigen::Matrix4d Hu = untwist(H, sym);
            if (bounds_ok(Hu, nullptr) && rms_on_surface(Hu) <= 1.05 * rh + 1e-9 * L) H = Hu;
          }
          bounds_ok(H, &s);
        }
        Polished out;
        out.H = H;
        out.s = s;
        out.rms_unrefined = rms_unrefined;
        // judged with the reverse term too, so that a fit grown over whole faces is not passed over
        // for one that lies on part of them
        out.cost = cost(H) + (refine_face.empty() ? 0.0 : reverse_pairs(H, s, nullptr, nullptr));
        return out;
      };
      Polished chosen;
      if (rr.found) {
        chosen = polish(rr.H, rr.cost);
        chosen.sample = rr.sample;
      }
      if (pose_pair >= 0) {
        Polished alt = polish(pose_h, pose_cost);
        alt.sample.fill(pose_pair);
        if (!rr.found || alt.cost < 0.75 * chosen.cost) chosen = alt;  // RANSAC's fit unless clearly worse
      }
      rr.sample = chosen.sample;
      const Eigen::Matrix4d H = chosen.H;
      const double s = chosen.s;
      const double rms_unrefined = chosen.rms_unrefined;
      const double err = quantile_error(H);
      const double tol = p.accept_error * L * s;
      // Validation on the dense surfaces: mapped reference samples on the target, normals agreeing.
      Points mapped(static_cast<Eigen::Index>(dense_rows.size()), 3);
      int on = 0;
      double sq = 0;
      bool finite_map = true;  // false when H's plane at infinity cuts the reference feature
      for (std::size_t k = 0; k < dense_rows.size(); ++k) {
        const Eigen::Vector3d x = R.dense.points.row(dense_rows[k]);
        const Eigen::Vector3d y = apply_transform(H, x);
        finite_map = finite_map && y.allFinite();
        mapped.row(static_cast<Eigen::Index>(k)) = y;
        int j;
        const double e = surface_distance(T, y, &j);
        sq += std::isfinite(e) ? e * e : tol * tol * 100;
        if (j < 0 || !(e <= tol)) continue;
        const Eigen::Vector3d nr = R.dense_normals.row(dense_rows[k]);
        const Eigen::Vector3d nm = transform_jacobian(H, x).inverse().transpose() * nr;
        if (nm.normalized().dot(T.dense_normals.row(j)) > 0.5) ++on;
      }
      const double score = static_cast<double>(on) / static_cast<double>(std::max<std::size_t>(1, dense_rows.size()));
      // Key point agreement (paper's shape index, used as a check): the reference key points must land
      // near target key points of a similar shape index, not on plain or differently curved surface.
      int agree = 0;
      for (const Eigen::Index i : core_keys) {
        const Eigen::Vector3d y = apply_transform(H, R.keys.row(i).transpose());
        tkey_tree.radius(y, tol + T.sparse_h, near_keys, near_d2);
        bool ok = false;
        for (int j : near_keys) ok = ok || std::abs(T.key_si(j) - R.key_si(i)) <= p.key_si_tolerance;
        agree += ok ? 1 : 0;
      }
      const double key_agreement = static_cast<double>(agree) / static_cast<double>(std::max<std::size_t>(1, core_keys.size()));
      bool accepted = finite_map && err <= p.accept_error * L && score >= p.min_score && key_agreement >= p.min_key_agreement;
      double obstructed = 0;
      if ((accepted || debug) && p.max_obstructed < 1) {
        obstructed = clearance.obstructed(H, [&](const Eigen::Vector3d& y) { return target_distance(y); }, 0.5 * s * R.dense_h + T.dense_h,
                                          3 * R.dense_h + 2 * err);
        accepted = accepted && obstructed <= p.max_obstructed;
      }
      double partial_faces = 0;
      if ((accepted || debug) && whole_faces.reference) {
        partial_faces = whole_faces.partial_share(H, tol + T.dense_h, kWholeFaceFill);
        accepted = accepted && partial_faces <= p.max_partial_faces;
      }
      const Deformation df = deformation(H, rlo, rhi);
      if (debug) {
        const Eigen::Vector3d c0 = tp.row(rr.sample[0]);
        std::fprintf(stderr, "debug: cluster %zu pairs %zu at (%.1f %.1f %.1f): err/L %.3f score %.2f keys %.2f vol %.2f stretch %.2f..%.2f persp %.2f obstructed %.2f partial %.2f it %d -> %s\n",
                     order[oi], pairs.size(), c0.x(), c0.y(), c0.z(), err / L, score, key_agreement, df.volume_ratio, df.scale_min, df.scale_max,
                     df.perspective, obstructed, partial_faces, rr.iterations, accepted ? "accepted" : "rejected");
        const Eigen::Vector3d rc = 0.5 * (rlo + rhi);
        const Eigen::Matrix3d J = transform_jacobian(H, rc);
        const Eigen::Vector3d m = apply_transform(H, rc);
        std::fprintf(stderr, "   ref center -> (%.1f %.1f %.1f)  J = [%.2f %.2f %.2f; %.2f %.2f %.2f; %.2f %.2f %.2f]\n", m.x(), m.y(), m.z(),
                     J(0, 0), J(0, 1), J(0, 2), J(1, 0), J(1, 1), J(1, 2), J(2, 0), J(2, 1), J(2, 2));
      }
      // Pairs whose target point this hypothesis explains are removed either way; on rejection only
      // those around its sample, so the next search looks elsewhere.
      // An accepted hypothesis that explains no pair (the same instance found again, its pairs gone)
      // drops those around its sample too, so the search goes on elsewhere instead of ending.
      KdTree3 mtree(mapped);
      auto remaining = [&](bool explained_by_map) {  // the pairs left after dropping one way or the other
        const double reach = explained_by_map ? std::max(2 * tol, 2 * T.sparse_h) : 0.1 * L * s;
        std::vector<KeyPointPair> left;
        for (std::size_t i = 0; i < pairs.size(); ++i) {
          bool drop = false;
          if (explained_by_map) {
            double d2;
            mtree.nearest(T.keys.row(pairs[i].tgt).transpose(), &d2);
            drop = std::sqrt(d2) <= reach;
          } else {
            for (int si : rr.sample) drop = drop || (tp.row(static_cast<Eigen::Index>(i)) - tp.row(si)).norm() <= reach;
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
        continue;
      }
      failures = 0;
      Instance inst;
      Match& mt = inst.match;
      mt.transform = H;
      mt.score = score;
      mt.max_error = err * s;
      mt.rms_error = std::sqrt(sq / static_cast<double>(std::max<std::size_t>(1, dense_rows.size())));
      mt.rms_error_unrefined = rms_unrefined;
      mt.scale = s;
      mt.pairs = static_cast<int>(explained);
      mt.key_agreement = key_agreement;
      mt.stretch_min = df.scale_min;
      mt.stretch_max = df.scale_max;
      mt.perspective = df.perspective;
      mt.obstructed = obstructed;
      // Covered target region: dense samples near the mapped reference.
      const double cov = tol + R.dense_h * s;
      const Eigen::Vector3d lo = mapped.colwise().minCoeff().transpose() - Eigen::Vector3d::Constant(cov);
      const Eigen::Vector3d hi = mapped.colwise().maxCoeff().transpose() + Eigen::Vector3d::Constant(cov);
      std::vector<int> idx;
      std::vector<float> dd;
      for (Eigen::Index j = 0; j < T.dense.points.rows(); ++j) {
        const Eigen::Vector3d q = T.dense.points.row(j);
        if ((q.array() < lo.array()).any() || (q.array() > hi.array()).any()) continue;
        double d2;
        mtree.nearest(q, &d2);
        if (std::sqrt(d2) <= cov) inst.covered.push_back(static_cast<int>(j));
      }
      if (inst.covered.empty()) continue;
      Eigen::Vector3d c = Eigen::Vector3d::Zero(), bmin = Eigen::Vector3d::Constant(INFINITY), bmax = -bmin;
      for (int j : inst.covered) {
        const Eigen::Vector3d q = T.dense.points.row(j);
        c += q;
        bmin = bmin.cwiseMin(q);
        bmax = bmax.cwiseMax(q);
      }
      mt.center = c / static_cast<double>(inst.covered.size());
      mt.bbox_min = bmin;
      mt.bbox_max = bmax;
      // Faces and triangles: covered area per face (triangle centroids near the mapped reference).
      std::vector<double> face_area(static_cast<std::size_t>(tmesh.num_faces + 1), 0.0), face_cov(face_area.size(), 0.0);
      for (Eigen::Index t = 0; t < tmesh.triangles.rows(); ++t) {
        const Eigen::Vector3d a = tmesh.vertices.row(tmesh.triangles(t, 0)), b = tmesh.vertices.row(tmesh.triangles(t, 1)),
                              e = tmesh.vertices.row(tmesh.triangles(t, 2));
        const double area = 0.5 * (b - a).cross(e - a).norm();
        const int f = tmesh.face_ids.size() ? tmesh.face_ids(t) : 0;
        if (f > 0 && f <= tmesh.num_faces) face_area[static_cast<std::size_t>(f)] += area;
        const Eigen::Vector3d g = (a + b + e) / 3.0;
        if ((g.array() < lo.array()).any() || (g.array() > hi.array()).any()) continue;
        double d2;
        mtree.nearest(g, &d2);
        if (std::sqrt(d2) > cov) continue;
        if (f > 0 && f <= tmesh.num_faces) face_cov[static_cast<std::size_t>(f)] += area;
        if (!tmesh.from_brep()) mt.triangles.push_back(static_cast<int>(t));
      }
      for (int f = 1; f <= tmesh.num_faces; ++f)
        if (face_area[static_cast<std::size_t>(f)] > 0 &&
            face_cov[static_cast<std::size_t>(f)] >= p.face_coverage * face_area[static_cast<std::size_t>(f)])
          mt.faces.push_back(f);
      found.push_back(std::move(inst));
    }
  }
  res.timings.push_back({"ransac", sw.lap()});

  // Each instance once: the better-scoring of two overlapping instances wins.
  report(progress, "result", 0);
  std::stable_sort(found.begin(), found.end(), [](const Instance& a, const Instance& b) { return a.match.score > b.match.score; });
  std::vector<const Instance*> kept;
  for (const Instance& f : found) {
    bool dup = false;
    for (const Instance* k : kept) {
      std::vector<int> both;
      std::set_intersection(f.covered.begin(), f.covered.end(), k->covered.begin(), k->covered.end(), std::back_inserter(both));
      const double denom = static_cast<double>(std::min(f.covered.size(), k->covered.size()));
      dup = dup || static_cast<double>(both.size()) > p.max_overlap * denom;
    }
    if (!dup) kept.push_back(&f);
  }
  for (const Instance* k : kept) res.matches.push_back(k->match);
  // Stable order for the user: by position (x, then y, then z), then score (a strict weak order).
  sort_matches(res.matches);
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
template <class Run>
Result with_fallback(const Params& params, Run run) {
  const bool can_fall_back = params.ridge_rut_fallback > 0 && !(params.ridge_rut_spacing > 0);
  Result res;
  std::string why;
  try {
    res = run(params);
    if (!res.matches.empty() || !can_fall_back) return res;
    why = "nothing found with the paper's key points";
  } catch (const NoKeyPoints& e) {
    if (!can_fall_back) throw;
    why = "the reference has too few of the paper's key points (caps, cups, saddles)";
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

// Two matches are one instance when they share more than max_overlap of the smaller one's faces
// (triangles for mesh input; boxes when neither is listed).
bool same_instance(const Match& a, const Match& b, double max_overlap) {
  auto shared = [&](std::vector<int> x, std::vector<int> y) {
    std::sort(x.begin(), x.end());
    std::sort(y.begin(), y.end());
    std::vector<int> both;
    std::set_intersection(x.begin(), x.end(), y.begin(), y.end(), std::back_inserter(both));
    return static_cast<double>(both.size()) > max_overlap * static_cast<double>(std::min(x.size(), y.size()));
  };
  if (!a.faces.empty() && !b.faces.empty()) return shared(a.faces, b.faces);
  if (!a.triangles.empty() && !b.triangles.empty()) return shared(a.triangles, b.triangles);
  const Eigen::Vector3d lo = a.bbox_min.cwiseMax(b.bbox_min), hi = a.bbox_max.cwiseMin(b.bbox_max);
  if ((lo.array() > hi.array()).any()) return false;
  const double pad = 1e-9 + 0.01 * ((a.bbox_max - a.bbox_min).norm() + (b.bbox_max - b.bbox_min).norm());
  auto vol = [&](const Eigen::Vector3d& l, const Eigen::Vector3d& h) { return ((h - l).array() + pad).prod(); };
  return vol(lo, hi) > max_overlap * std::min(vol(a.bbox_min, a.bbox_max), vol(b.bbox_min, b.bbox_max));
}

// Matches of the mirrored reference join the result: their H maps the original reference (H M), and
// where a mirrored and a direct match are the same instance the better score wins (the direct one on
// a tie, so that a symmetric feature is never reported as mirrored).
void merge_mirrored(Result& res, Result mirrored, const Eigen::Matrix4d& M, const Params& p) {
  for (Match& m : mirrored.matches) {
    m.transform = m.transform * M;
    m.transform /= m.transform(3, 3);
    m.mirrored = true;
    bool dup = false;
    for (Match& d : res.matches) {
      if (!same_instance(m, d, p.max_overlap)) continue;
      dup = true;
      if (m.score > d.score + 0.02) d = m;
      break;
    }
    if (!dup) res.matches.push_back(m);
  }
  sort_matches(res.matches);
  res.pairs_shot += mirrored.pairs_shot;
  res.pairs_ss += mirrored.pairs_ss;
  res.clusters += mirrored.clusters;
  for (const auto& t : mirrored.timings)
    if (t.first.rfind("target_", 0) != 0) res.timings.push_back({"mirror_" + t.first, t.second});
}

// The reference as searched: without its cut faces when it was cut out of a part (detect_cut_faces).
struct SearchedReference {
  TriangleMesh mesh;
  CutFaces cut;
};
SearchedReference searched_reference(const TriangleMesh& reference, const Params& p) {
  SearchedReference r;
  if (p.detect_cut_faces) r.cut = detect_cut_faces(reference);
  r.mesh = r.cut.triangles > 0 ? without_triangles(reference, r.cut.cut_triangle) : reference;
  return r;
}

template <class TargetFor>
Result search_within(const TriangleMesh& reference_in, const TriangleMesh& target, const Params& params_in, const ProgressFn& progress,
                     TargetFor target_for);

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
    return search_within(reference_in, target, params_in, checked, target_for);
  } catch (const Cancelled&) {
    if (!out_of_time) throw;
    std::ostringstream m;
    m << (target.source.empty() ? std::string("target") : target.source) << ": stopped after the time limit of "
      << params_in.time_limit << " s (time_limit)";
    throw TimeLimitExceeded(m.str());
  }
}

template <class TargetFor>
Result search_within(const TriangleMesh& reference_in, const TriangleMesh& target, const Params& params_in, const ProgressFn& progress,
                     TargetFor target_for) {
  const SearchedReference sr = searched_reference(reference_in, params_in);
  const TriangleMesh& reference = sr.mesh;
  check_sizes(reference, target, params_in);
  const FeatureCore fc = feature_core(reference_in, sr.cut);
  Result res = with_fallback(params_in, [&](const Params& params) {
    const double L = reference.diagonal();
    const ShapeDescription r = describe(reference, ShapeDescription::Role::Reference, L, params, progress);
    const std::shared_ptr<const ShapeDescription> t = target_for(L, params, progress);
    Result out = match_core(r, *t, target, params, progress, fc);
    if (params.mirror) {
      const auto& R = r.impl();
      out.reference_mirror_symmetric = is_mirror_symmetric(R.dense.points, R.dense_normals, 1.5 * R.dense_h);
      if (!out.reference_mirror_symmetric) {
        Eigen::Matrix4d M;
        const Eigen::Vector3d c = 0.5 * (R.box_min + R.box_max);
        const ShapeDescription rm = describe(mirrored_mesh(reference, c, &M), ShapeDescription::Role::Reference, L, params, progress);
        FeatureCore fm = fc;  // the mirror image's core: reflected through x = c.x()
        if (fc.set) {
          fm.lo.x() = 2 * c.x() - fc.hi.x();
          fm.hi.x() = 2 * c.x() - fc.lo.x();
        }
        merge_mirrored(out, match_core(rm, *t, target, params, progress, fm), M, params);
        out.mirror_searched = true;
      }
    }
    return out;
  });
  res.reference_closed = sr.cut.closed;
  res.reference_cut_faces = sr.cut.faces;
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
  return res;
}
}  // namespace

PreparedTarget::PreparedTarget(TriangleMesh mesh) : mesh_(std::move(mesh)) {}

Result PreparedTarget::extract(const TriangleMesh& reference, const Params& params_in, const ProgressFn& progress) {
  return search(reference, mesh_, params_in, progress, [&](double L, const Params& params, const ProgressFn& checked) {
    const std::string key = description_key(L, params);
    std::lock_guard<std::mutex> lock(mutex_);  // a second query for the same key waits instead of recomputing
    for (const auto& c : cache_)
      if (c.first == key) return c.second;
    auto t = std::make_shared<const ShapeDescription>(describe(mesh_, ShapeDescription::Role::Target, L, params, checked));
    cache_.emplace_back(key, t);
    ++built_;
    if (cache_.size() > 4) cache_.erase(cache_.begin());  // bounded memory
    return t;
  });
}

Result extract(const TriangleMesh& reference, const TriangleMesh& target, const Params& params_in, const ProgressFn& progress) {
  return search(reference, target, params_in, progress, [&](double L, const Params& params, const ProgressFn& checked) {
    // one description per pass (the fallback describes again with its own key points)
    return std::make_shared<const ShapeDescription>(describe(target, ShapeDescription::Role::Target, L, params, checked));
  });
}

}  // namespace fe
