// The paper's steps 1-3 for one shape (describe()), and the surface distances the matching stages
// measure on a description.
#include "description.h"

#include "curvature.h"
#include "skirt.h"

#include "featureextract/geometry.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <limits>
#include <sstream>
#include <unordered_map>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace fe {

ShapeStats ShapeDescription::stats() const { return impl_ ? impl_->stats : ShapeStats{}; }
double ShapeDescription::feature_size() const { return impl_ ? impl_->L : 0.0; }
ShapeDescription::Role ShapeDescription::role() const { return impl_ ? impl_->role : Role::Target; }
std::vector<std::pair<std::string, double>> ShapeDescription::timings() const { return impl_ ? impl_->timings : decltype(impl_->timings){}; }
const Points& ShapeDescription::dense_points() const { return impl_->dense.points; }
const Points& ShapeDescription::sparse_points() const { return impl_->sparse_points; }
const Points& ShapeDescription::key_points() const { return impl_->keys; }
const Eigen::VectorXd& ShapeDescription::key_shape_index() const { return impl_->key_si; }
std::vector<std::string> ShapeDescription::warnings() const { return impl_ ? impl_->warnings : std::vector<std::string>{}; }

void report(const ProgressFn& progress, const std::string& stage, double f) {
  if (progress && !progress(stage, std::min(1.0, std::max(0.0, f)))) throw Cancelled();
}

void side_by_side(const std::function<void()>& a, const std::function<void()>& b, bool parallel) {
#ifdef _OPENMP
  const int threads = parallel ? std::min(2, omp_get_max_threads()) : 1;
#else
  const int threads = 1;
  (void)parallel;
#endif
  std::exception_ptr failed[2];
#pragma omp parallel sections num_threads(threads)
  {
#pragma omp section
    {
      try {
        a();
      } catch (...) {
        failed[0] = std::current_exception();
      }
    }
#pragma omp section
    {
      try {
        b();
      } catch (...) {
        failed[1] = std::current_exception();
      }
    }
  }
  for (const std::exception_ptr& e : failed)
    if (e) std::rethrow_exception(e);
}

void set_threads(const Params& p) {
#ifdef _OPENMP
  omp_set_num_threads(thread_budget(p));
#endif
}

int thread_budget(const Params& p) {
#ifdef _OPENMP
  return p.threads > 0 ? p.threads : omp_get_num_procs();
#else
  return 1;
#endif
}

std::vector<std::pair<const char*, double>> descriptor_parameters(const Params& p) {
  return {{"dense_spacing", p.dense_spacing},         {"sparse_spacing", p.sparse_spacing},
          {"max_dense_points", static_cast<double>(p.max_dense_points)},
          {"normal_radius", p.normal_radius},         {"curvature_radius", p.curvature_radius},
          {"planar_curvedness", p.planar_curvedness}, {"shot_radius", p.shot_radius},
          {"shot_radii", p.shot_radii},               {"shot_radius_ratio", p.shot_radius_ratio},
          {"si_band", p.si_band},                     {"ridge_rut_spacing", p.ridge_rut_spacing},
          {"crease_key_points", p.crease_key_points ? 1.0 : 0.0},
          {"topology_hypotheses", p.topology_hypotheses ? 1.0 : 0.0}};
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

namespace {

int ladder_steps(double scale, double ratio) {
  return std::max(0, static_cast<int>(std::ceil(std::log(scale) / std::log(ratio) - 1e-9)));
}

}  // namespace

double dense_coarsening(const TriangleMesh& mesh, double L, const Params& p, const std::string& name) {
  const double h = p.dense_spacing * L;
  const double area = mesh_area(mesh);
  const double expected = area / (h * h);
  if (!(expected > static_cast<double>(p.max_dense_points))) return 1.0;
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
  return f * (1 + 1e-9);
}

Params coarsened(const Params& p, double f) {
  Params c = p;
  if (!(f > 1)) return c;
  c.sparse_spacing *= f;  // before dense_spacing: validate() wants dense <= sparse at every step
  c.dense_spacing *= f;
  c.normal_radius *= f;
  c.curvature_radius *= f;
  return c;
}

namespace {

// Steps 1 and 2 for a new description: dense and sparse samples, their normals, the kd-tree, the
// sparse samples' shape index.
void sample_and_index(const TriangleMesh& mesh, const TriangleMesh& skirt, double L, const Params& p, const ProgressFn& progress, const std::string& who,
                      const std::string& name, ShapeDescription::Impl* d, Stopwatch& sw) {
  // Step 1: dense and sparse samples.
  report(progress, who + ": sampling", 0);
  d->dense_h = p.dense_spacing * L;
  d->sparse_h = p.sparse_spacing * L;
  const double f = dense_coarsening(mesh, L, p, name);
  if (f > 1) {
    d->dense_h *= f;
    d->sparse_h = std::max(d->sparse_h, 2.5 * d->dense_h);
    std::ostringstream w;
    w << name << ": surface too large for the dense spacing (more than max_dense_points samples); spacing increased " << f
      << "x, small features may be missed";
    d->warnings.push_back(w.str());
  }
  // one kd-tree over the dense samples for normals, curvature, creases and the matching (it was built
  // five times: a second on CTC-02's 929,067 samples); the sparse samples (their own random stream)
  // are drawn on the other core meanwhile
  Samples sparse;
  side_by_side(
      [&] {
        d->dense = sample_surface(mesh, d->dense_h, p.seed);
        d->dense_tree = std::make_shared<KdTree3>(d->dense.points);
      },
      [&] { sparse = sample_surface(mesh, d->sparse_h, p.seed + 1); });
  d->box_min = mesh.vertices.colwise().minCoeff();
  d->box_max = mesh.vertices.colwise().maxCoeff();
  // A reference's open border (picked faces, a cut reference without its cut faces, a region of an
  // STL) is continued by its skirt (skirt.h) in the support of normals, shape index and descriptors:
  // on the part the surface goes on past it, and a support that stops there describes another shape.
  // The skirt is support only: no sample on it is a key point, and matches are judged without it.
  Samples on_skirt, support;  // the skirt's samples; the dense samples and those, when there is a skirt
  std::shared_ptr<KdTree3> support_tree;
  if (skirt.triangles.rows() > 0) {
    on_skirt = sample_surface(skirt, d->dense_h, p.seed + 2);
    auto both = [](const auto& a, const auto& b) {
      std::decay_t<decltype(a)> c(a.rows() + b.rows(), a.cols());
      c << a, b;
      return c;
    };
    support = {both(d->dense.points, on_skirt.points), both(d->dense.normals, on_skirt.normals),
               both(d->dense.face_ids, on_skirt.face_ids), both(d->dense.triangle_ids, Eigen::VectorXi::Constant(on_skirt.points.rows(), -1))};
    support_tree = std::make_shared<KdTree3>(support.points);
    if (std::getenv("FE_DEBUG"))
      std::fprintf(stderr, "debug: reference skirt: %ld triangles, %ld samples\n", static_cast<long>(skirt.triangles.rows()), static_cast<long>(on_skirt.size()));
  }
  const bool skirted = support_tree != nullptr;
  const KdTree3& tree = skirted ? *support_tree : *d->dense_tree;
  const Samples& sup = skirted ? support : d->dense;
  d->timings.push_back({who + "_sampling", sw.lap()});

  // Step 2a: normals (PCA over dense samples, oriented by the triangles).
  report(progress, who + ": normals", 0);
  const double rn = p.normal_radius * L;
  d->dense_normals = estimate_normals(tree, sup, d->dense, rn);
  d->sparse_normals = estimate_normals(tree, sup, sparse, rn);
  if (skirted) {
    d->support_normals.resize(support.points.rows(), 3);
    d->support_normals << d->dense_normals, estimate_normals(tree, sup, on_skirt, rn);
    d->support_points = support.points;
  }
  const Points& sup_n = skirted ? d->support_normals : d->dense_normals;
  d->timings.push_back({who + "_normals", sw.lap()});

  // Step 2b: shape index at sparse samples.
  report(progress, who + ": shape index", 0);
  const Eigen::MatrixX2d k = principal_curvatures(tree, sup.points, sup_n, sparse.points, d->sparse_normals, p.curvature_radius * L);
  // Sharp creases (machined features: planes meeting at edges and corners) look planar to the quadric
  // fit over same-side neighbours; there the crease's own shape index is used, offset so that sharp
  // and filleted shapes stay apart (kCreaseShapeIndex).
  const Eigen::VectorXd crease = p.crease_key_points ? crease_shape_index(tree, sup, sparse, p.curvature_radius * L)
                                                     : Eigen::VectorXd::Constant(k.rows(), std::numeric_limits<double>::quiet_NaN());
  d->sparse_si.resize(k.rows());
  for (Eigen::Index i = 0; i < k.rows(); ++i) {
    double si = shape_index(k(i, 0), k(i, 1), p.planar_curvedness / L);
    if ((si == kPlanarShapeIndex || !std::isfinite(si)) && std::isfinite(crease(i))) si = kCreaseShapeIndex + crease(i);
    d->sparse_si(i) = si;
  }
  d->sparse_points = std::move(sparse.points);
  d->timings.push_back({who + "_shape_index", sw.lap()});
}

ShapeDescription describe_impl(const TriangleMesh& mesh, ShapeDescription::Role role, double L, const Params& p,
                               const ProgressFn& progress, const ShapeDescription::Impl* base) {
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

  if (base) {
    // Steps 1 and 2 as the base made them (same mesh, size, seed and parameters but ridge_rut_spacing).
    d->dense_h = base->dense_h;
    d->sparse_h = base->sparse_h;
    d->dense = base->dense;
    d->dense_normals = base->dense_normals;
    d->dense_tree = base->dense_tree;
    d->box_min = base->box_min;
    d->box_max = base->box_max;
    d->sparse_points = base->sparse_points;
    d->sparse_normals = base->sparse_normals;
    d->sparse_si = base->sparse_si;
    d->support_points = base->support_points;
    d->support_normals = base->support_normals;
    d->warnings = base->warnings;
  } else {
    // the skirt (skirt.h) as wide as the largest SHOT support; none (no triangles) without border_skirt
    const TriangleMesh skirt = is_ref && p.border_skirt ? border_skirt(mesh, p.shot_radius * L * std::pow(p.shot_radius_ratio, p.shot_radii - 1))
                                                         : TriangleMesh{};
    sample_and_index(mesh, skirt, L, p, progress, who, name, d.get(), sw);
  }

  // Step 3: key points.
  std::vector<Eigen::Index> key;
  std::vector<double> key_si;
  // Ridge and rut points (cylinders: holes, lugs, bosses, fillets) are not key points in the paper;
  // with ridge_rut_spacing > 0 they are kept too, thinned to one per cube of that size, so that
  // features made of cylinders still have key points without flooding the matching.
  std::unordered_map<std::uint64_t, char> ridge_cells;
  const double ridge_h = p.ridge_rut_spacing * L;
  const Points& sparse_points = d->sparse_points;
  const Eigen::Vector3d origin = sparse_points.size() ? Eigen::Vector3d(sparse_points.colwise().minCoeff()) : Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < d->sparse_si.size(); ++i) {
    const double si = d->sparse_si(i);
    bool take = is_key_shape_index(si, p.si_band);
    if (!take && ridge_h > 0 && si >= 0) {
      const Eigen::Vector3d g = ((sparse_points.row(i).transpose() - origin) / ridge_h).array().floor();
      const std::uint64_t cell = (static_cast<std::uint64_t>(g.x()) & 0x1FFFFF) << 42 |
                                 (static_cast<std::uint64_t>(g.y()) & 0x1FFFFF) << 21 | (static_cast<std::uint64_t>(g.z()) & 0x1FFFFF);
      take = ridge_cells.emplace(cell, 1).second;
    }
    if (take) {
      key.push_back(i);
      key_si.push_back(si);
    }
  }

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
    keys.row(static_cast<Eigen::Index>(i)) = d->sparse_points.row(key[i]);
    key_n.row(static_cast<Eigen::Index>(i)) = d->sparse_normals.row(key[i]);
  }
  report(progress, who + ": SHOT descriptors", 0);
  auto after_radius = [&](std::size_t r) {
    return !progress || progress(who + ": SHOT descriptors", static_cast<double>(r + 1) / static_cast<double>(radii.size()));
  };
  ShotSet shot;
  const bool skirted = d->support_points.rows() > 0;
  const Points& support = skirted ? d->support_points : d->dense.points;
  const Points& support_normals = skirted ? d->support_normals : d->dense_normals;
  if (!base) {
    shot = compute_shot(keys, key_n, support, support_normals, d->dense_h, radii, p.threads, after_radius);
  } else {
    // A key point's descriptors depend on it and the support only: the base's rows are copied, and
    // SHOT runs on the key points the base does not have (the ridge and rut points).
    std::unordered_map<Eigen::Index, Eigen::Index> base_row;
    for (std::size_t a = 0; a < base->key_sparse.size(); ++a) base_row.emplace(base->key_sparse[a], static_cast<Eigen::Index>(a));
    std::vector<Eigen::Index> fresh;
    for (std::size_t i = 0; i < key.size(); ++i)
      if (!base_row.count(key[i])) fresh.push_back(static_cast<Eigen::Index>(i));
    Points fk(static_cast<Eigen::Index>(fresh.size()), 3), fn(static_cast<Eigen::Index>(fresh.size()), 3);
    for (std::size_t a = 0; a < fresh.size(); ++a) {
      fk.row(static_cast<Eigen::Index>(a)) = keys.row(fresh[a]);
      fn.row(static_cast<Eigen::Index>(a)) = key_n.row(fresh[a]);
    }
    const ShotSet computed = compute_shot(fk, fn, support, support_normals, d->dense_h, radii, p.threads, after_radius);
    const Eigen::Index K = keys.rows();
    shot.desc.resize(K, computed.desc.cols());
    shot.valid.resize(K, computed.valid.cols());
    shot.lrf.resize(K, computed.lrf.cols());
    if (base->shot.desc.cols() != shot.desc.cols()) throw std::invalid_argument("describe_reusing: the base has other SHOT radii");
    std::size_t a = 0;
    for (Eigen::Index i = 0; i < K; ++i) {
      const auto it = base_row.find(key[static_cast<std::size_t>(i)]);
      if (it == base_row.end()) {
        shot.desc.row(i) = computed.desc.row(static_cast<Eigen::Index>(a));
        shot.valid.row(i) = computed.valid.row(static_cast<Eigen::Index>(a));
        shot.lrf.row(i) = computed.lrf.row(static_cast<Eigen::Index>(a));
        ++a;
      } else {
        shot.desc.row(i) = base->shot.desc.row(it->second);
        shot.valid.row(i) = base->shot.valid.row(it->second);
        shot.lrf.row(i) = base->shot.lrf.row(it->second);
      }
    }
  }
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
  d->key_sparse.resize(keep.size());
  for (std::size_t a = 0; a < keep.size(); ++a) d->key_sparse[a] = key[static_cast<std::size_t>(keep[a])];
  d->timings.push_back({who + "_shot", sw.lap()});
  if (p.topology_hypotheses && base && base->params.topology_hypotheses) {
    d->regions = base->regions;
  } else if (p.topology_hypotheses) {
    report(progress, who + ": regions", 0);
    d->regions = region_graph(mesh);
    d->timings.push_back({who + "_regions", sw.lap()});
  }

  ShapeStats& s = d->stats;
  s.triangles = static_cast<std::size_t>(mesh.triangles.rows());
  s.faces = static_cast<std::size_t>(mesh.num_faces);
  s.dense_points = d->dense.size();
  s.sparse_points = static_cast<std::size_t>(d->sparse_points.rows());
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
    // The paper's key points all in one spot (a counterbore's concave rim where the tessellation
    // bends it: 6 points within 0.14 L) cannot place the feature: pairs drawn from one spot leave it
    // free to turn about it, and instances elsewhere fail the key agreement. Like too few, when the
    // search can fall back on ridge and rut key points.
    if (!(p.ridge_rut_spacing > 0) && p.ridge_rut_fallback > 0 && d->keys.rows() > 0) {
      const double spread = (d->keys.colwise().maxCoeff() - d->keys.colwise().minCoeff()).norm();
      if (spread < kMinKeySpread * L) {
        std::ostringstream e;
        e.precision(2);
        e << name << ": the reference's " << d->keys.rows() << " key points lie within " << spread / L << " L of each other: too close together to place it";
        throw NoKeyPoints(e.str());
      }
    }
  }
  return ShapeDescription(d);
}

}  // namespace

ShapeDescription describe(const TriangleMesh& mesh, ShapeDescription::Role role, double L, const Params& p,
                          const ProgressFn& progress) {
  return describe_impl(mesh, role, L, p, progress, nullptr);
}

ShapeDescription describe_reusing(const TriangleMesh& mesh, const ShapeDescription& base, const Params& p,
                                  const ProgressFn& progress) {
  if (base.empty()) throw std::invalid_argument("describe_reusing: empty base");
  const ShapeDescription::Impl& b = base.impl();
  const auto mine = descriptor_parameters(p), theirs = descriptor_parameters(b.params);
  for (std::size_t i = 0; i < mine.size(); ++i)
    if (mine[i].second != theirs[i].second && std::string(mine[i].first) != "ridge_rut_spacing")
      throw std::invalid_argument(std::string("describe_reusing: the base was described with another ") + mine[i].first);
  if (p.seed != b.params.seed || p.scale_min != b.params.scale_min || p.scale_max != b.params.scale_max)
    throw std::invalid_argument("describe_reusing: the base was described with another seed or scale range");
  if (mesh.triangles.rows() != static_cast<Eigen::Index>(b.stats.triangles) || mesh.diagonal() != b.stats.diagonal)
    throw std::invalid_argument("describe_reusing: the base describes another mesh");
  return describe_impl(mesh, b.role, b.L, p, progress, &b);
}

namespace {
// surface_distance measured at dense sample j, which lies d2 (squared) from p.
double distance_at_sample(const ShapeDescription::Impl& t, const Eigen::Vector3d& p, int j, double d2) {
  const Eigen::Vector3d q = t.dense.points.row(j), n = t.dense_normals.row(j);
  const double dn = std::abs((p - q).dot(n));
  const double dt = std::sqrt(std::max(0.0, d2 - dn * dn));
  const double over = std::max(0.0, dt - t.dense_h);
  return std::sqrt(dn * dn + over * over);
}

}  // namespace

double surface_distance(const ShapeDescription::Impl& t, const Eigen::Vector3d& p, int* nearest) {
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

double facing_surface_distance(const ShapeDescription::Impl& t, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double reach, int* nearest) {
  *nearest = -1;
  thread_local std::vector<int> idx;
  thread_local std::vector<float> d2;
  t.dense_tree->radius(p, reach, idx, d2);
  double best = INFINITY;
  for (std::size_t c = 0; c < idx.size(); ++c) {
    if (n.dot(t.dense_normals.row(idx[c])) < 0.5) continue;
    const double e = distance_at_sample(t, p, idx[c], d2[c]);
    if (e < best) best = e, *nearest = idx[c];
  }
  return best;
}

// Deterministic subsample of at most n row indices.
std::vector<Eigen::Index> stride_rows(Eigen::Index rows, Eigen::Index n) {
  std::vector<Eigen::Index> r;
  const double step = std::max(1.0, static_cast<double>(rows) / static_cast<double>(n));
  for (double x = 0; x < static_cast<double>(rows); x += step) r.push_back(static_cast<Eigen::Index>(x));
  return r;
}

std::vector<Eigen::Index> stride_subset(const std::vector<Eigen::Index>& rows, Eigen::Index n) {
  std::vector<Eigen::Index> r;
  for (Eigen::Index i : stride_rows(static_cast<Eigen::Index>(rows.size()), n)) r.push_back(rows[static_cast<std::size_t>(i)]);
  return r;
}

}  // namespace fe
