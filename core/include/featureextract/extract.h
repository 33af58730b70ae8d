// The one entry point: extract(reference, target, params). The CLI, the Python bindings and the
// FreeCAD workbench all call it (or its two halves, describe() + match(), to reuse a target).
#pragma once

#include "featureextract/mesh.h"
#include "featureextract/params.h"
#include "featureextract/result.h"

#include <functional>
#include <memory>
#include <mutex>
#include <string>

namespace fe {

/// Progress: stage name and fraction in [0, 1] of that stage. Return false to cancel (extract then
/// throws fe::Cancelled). Called from the calling thread only.
using ProgressFn = std::function<bool(const std::string& stage, double fraction)>;

/// Steps 1-3 of the paper for one shape: samples, normals, shape index, key points, SHOT.
/// Immutable once built; holds what match() needs. Descriptors depend on the feature size L
/// (the reference diagonal), so a target description is reusable for references of the same L.
class ShapeDescription {
 public:
  enum class Role { Reference, Target };
  struct Impl;
  ShapeDescription() = default;
  explicit ShapeDescription(std::shared_ptr<const Impl> impl) : impl_(std::move(impl)) {}
  bool empty() const { return !impl_; }
  const Impl& impl() const { return *impl_; }
  ShapeStats stats() const;
  double feature_size() const;
  Role role() const;
  /// Seconds per stage spent building it.
  std::vector<std::pair<std::string, double>> timings() const;
  std::vector<std::string> warnings() const;
  /// Step 1-3 outputs, for display: dense and sparse samples, key points and their shape index.
  const Points& dense_points() const;
  const Points& sparse_points() const;
  const Points& key_points() const;
  const Eigen::VectorXd& key_shape_index() const;

 private:
  std::shared_ptr<const Impl> impl_;
};

/// Describes a shape. `feature_size` is L, the reference diagonal (pass reference.diagonal()).
/// Throws InputError (e.g. "reference has no distinctive key points"), Cancelled.
ShapeDescription describe(const TriangleMesh& mesh, ShapeDescription::Role role,
                          double feature_size, const Params& params, const ProgressFn& progress = {});

/// Steps 4-6: pairs, clusters, RANSAC, validation. `target` must be described with the same
/// feature size and parameters that affect descriptors; throws std::invalid_argument otherwise.
Result match(const ShapeDescription& reference, const ShapeDescription& target,
             const TriangleMesh& target_mesh, const Params& params, const ProgressFn& progress = {});

/// A target whose descriptions are kept for reuse: extracting several references from the same
/// target describes it once per distinct feature size and descriptor parameters (not per query).
class PreparedTarget {
 public:
  explicit PreparedTarget(TriangleMesh mesh);
  const TriangleMesh& mesh() const { return mesh_; }
  /// Same as extract(reference, mesh(), params, progress), reusing a matching description.
  Result extract(const TriangleMesh& reference, const Params& params = {}, const ProgressFn& progress = {});
  /// How many target descriptions were computed so far (steps 1-3 on the target).
  int descriptions_built() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return built_;
  }

 private:
  TriangleMesh mesh_;
  // key: L + descriptor parameters. Guarded by mutex_, so that several threads may query one target;
  // a query holds its own reference to the description while it matches.
  std::vector<std::pair<std::string, std::shared_ptr<const ShapeDescription>>> cache_;
  mutable std::mutex mutex_;
  int built_ = 0;
};

/// The feature size L as the search uses it: L itself if `steps` is 0, else the nearest size
/// 2^(k / steps) (Params::size_ladder), so that features of nearby sizes share target descriptions.
double size_on_ladder(double L, int steps);

/// All six steps. Throws InputError for bad input (message names the shape), Cancelled.
/// Instances scale_min to scale_max times the reference are searched; one pass covers 0.8-2.6, and a
/// wider range (1/3-3, issue 9) is searched in scale bands: one more pass per band, with the
/// reference scaled to the band and the target described at that size (finer below 0.8, so a band
/// for small instances costs more than the default search). Matches of every band are merged; each
/// reports its own scale. A band the part cannot be described for is skipped with a warning.
Result extract(const TriangleMesh& reference, const TriangleMesh& target, const Params& params = {},
               const ProgressFn& progress = {});

}  // namespace fe
