// Internal: what describe() computes for a shape (the paper's steps 1-3), and the small tools the
// matching stages (match() in extract.cpp, hypothesis.h, refine.h, ...) share to use it.
#pragma once

#include "featureextract/extract.h"
#include "kdtree.h"
#include "regions.h"
#include "shot.h"

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <utility>
#include <vector>

namespace fe {

/// A reference whose paper key points all lie within this share of L of each other cannot be placed
/// by them (describe() throws NoKeyPoints, and the search falls back on ridge and rut key points).
/// The development references that are searched with the paper's key points spread 0.26-0.89 L.
constexpr double kMinKeySpread = 0.2;

struct ShapeDescription::Impl {
  Role role = Role::Target;
  double L = 0;          // feature size (reference diagonal)
  Params params;
  double dense_h = 0, sparse_h = 0;
  Samples dense;
  Points dense_normals;  // PCA normals of the dense samples
  // a reference with an open border (border_skirt): the dense samples and its skirt's (skirt.h), the
  // support of its normals, shape index and SHOT, and their normals; empty otherwise
  Points support_points, support_normals;
  std::shared_ptr<KdTree3> dense_tree;
  Points sparse_points;
  Points sparse_normals;          // PCA normals of the sparse samples
  Eigen::VectorXd sparse_si;      // shape index of every sparse sample (crease index where planar)
  std::vector<Eigen::Index> key_sparse;  // the sparse sample each key point is
  Points keys, key_normals;
  Eigen::VectorXd key_si;
  ShotSet shot;
  int m = 0, D = 0, U = 0;  // radii per descriptor; target ladder steps below / above
  Eigen::Vector3d box_min, box_max;
  RegionGraph regions;  // regions bounded by sharp edges and how they meet (topology.h)
  ShapeStats stats;
  std::vector<std::pair<std::string, double>> timings;
  std::vector<std::string> warnings;
};

/// The reference has too few of the paper's key points (the search's fallback tries ridge and rut points).
struct NoKeyPoints : InputError {
  using InputError::InputError;
};

/// The parameters that shape a description (steps 1-3) besides the feature size, the seed and (for
/// a target) the scale range: match() requires them equal, and they key PreparedTarget's cache.
std::vector<std::pair<const char*, double>> descriptor_parameters(const Params& p);

/// describe() that reuses `base`: a description of the same mesh, for the same feature size, seed,
/// scale range and parameters except ridge_rut_spacing (the search's first pass, before its
/// ridge-and-rut fallback). Its samples, normals, kd-tree and shape indices are taken as they are,
/// and the SHOT descriptors of the key points both have are copied: the result is the description
/// describe() would make, without computing those again. Throws std::invalid_argument when `base`
/// does not fit.
ShapeDescription describe_reusing(const TriangleMesh& mesh, const ShapeDescription& base, const Params& p,
                                  const ProgressFn& progress = {});

/// Progress report of a stage (fraction clamped to 0..1); throws Cancelled when the callback says stop.
void report(const ProgressFn& progress, const std::string& stage, double f);

/// OpenMP's thread count from Params::threads (0: every core).
void set_threads(const Params& p);

/// The threads a search may use: Params::threads, or every core for 0 (1 without OpenMP).
int thread_budget(const Params& p);
/// Runs two independent jobs side by side (OpenMP sections, on two threads where more than one is
/// allowed; one after the other when `parallel` is false), then rethrows the first one's exception.
void side_by_side(const std::function<void()>& a, const std::function<void()>& b, bool parallel = true);

struct Stopwatch {
  std::chrono::steady_clock::time_point t0 = std::chrono::steady_clock::now();
  double lap() {
    const auto t = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(t - t0).count();
    t0 = t;
    return s;
  }
};

/// Surface area of a triangle mesh.
double mesh_area(const TriangleMesh& m);

/// How many times coarser than p.dense_spacing the dense samples of `mesh` must be, for a feature of
/// size L, to stay within p.max_dense_points (1 when they fit). Throws InputError naming `name` when
/// they would be more than 10x coarser: such samples cannot show the feature.
double dense_coarsening(const TriangleMesh& mesh, double L, const Params& p, const std::string& name);

/// p with the sample spacings and the neighbourhood radii of normals and curvature f times larger:
/// the same number of samples per neighbourhood at a coarser spacing. A target that must be sampled
/// coarser is matched with a reference described by the same parameters, so that both sides' normals,
/// shape index and SHOT see the same density (extract()).
Params coarsened(const Params& p, double f);

/// Distance from p to a shape's sampled surface: point-to-plane at the nearest dense sample, with the
/// tangential offset beyond one sample spacing added back (so points off the edge of a surface
/// count). The nearest sample's index in *nearest (-1 if none); +inf for an empty shape.
double surface_distance(const ShapeDescription::Impl& t, const Eigen::Vector3d& p, int* nearest = nullptr);

/// surface_distance where only values below `cap` matter (errors truncated at a penalty): the same
/// value and nearest sample whenever the distance is below cap; cap itself, with *nearest = -1, when
/// no sample lies near enough for it to be. Far points stop the tree search early.
double surface_distance_capped(const ShapeDescription::Impl& t, const Eigen::Vector3d& p, double cap, int* nearest);

/// Where two solids touch (an assembly's contact faces: a plate lying on a worktop), both faces are
/// sampled, one on the other with opposite normals, and the nearest sample to p is either. The nearest
/// sample within `reach` of p that faces n (normal . n >= 0.5): its surface_distance, its index in
/// *nearest; +inf and -1 when none does.
double facing_surface_distance(const ShapeDescription::Impl& t, const Eigen::Vector3d& p, const Eigen::Vector3d& n, double reach, int* nearest);

/// Deterministic subsample of at most n of the row indices 0..rows-1 (evenly strided).
std::vector<Eigen::Index> stride_rows(Eigen::Index rows, Eigen::Index n);

/// At most n of `rows`, evenly strided.
std::vector<Eigen::Index> stride_subset(const std::vector<Eigen::Index>& rows, Eigen::Index n);

}  // namespace fe
