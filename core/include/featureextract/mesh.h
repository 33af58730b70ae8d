// Plain data shared by every stage: a triangle soup with per-triangle B-rep face ids, and point
// samples drawn from it. No PCL or OpenCASCADE types here (see README, "Layout").
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace fe {

using Points = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;     // N x 3
using Triangles = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;     // T x 3, 0-based

/// A triangle soup. Topology is never used: triangles need not share vertices, be welded or
/// manifold (paper section 3.1: only sampled points matter).
struct TriangleMesh {
  Points vertices;            ///< #V x 3, model units (mm for STEP parts)
  Triangles triangles;        ///< #T x 3, 0-based rows of `vertices`, counter-clockwise = outward
  Eigen::VectorXi face_ids;   ///< #T; 1-based B-rep face number (FreeCAD's FaceN) or 0 for mesh input
  int num_faces = 0;          ///< number of B-rep faces (0 for mesh input)
  std::string source;         ///< file name or description, used in messages
  std::size_t dropped_degenerate = 0;  ///< zero-area triangles removed while reading
  std::size_t reoriented = 0;          ///< triangles flipped to agree with their neighbours

  bool from_brep() const { return num_faces > 0; }
  /// Axis-aligned bounding-box diagonal length.
  double diagonal() const;
};

/// Bad or unreadable input. what() is one line: "FILE: problem".
struct InputError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Thrown by extract() when the progress callback asked to stop.
struct Cancelled : std::runtime_error {
  Cancelled() : std::runtime_error("cancelled") {}
};

/// Thrown by extract() when the run took longer than Params::time_limit. what(): one line.
struct TimeLimitExceeded : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Points sampled on a mesh, with oriented normals (paper step 1, "dense" and "sparse" sets).
struct Samples {
  Points points;              ///< N x 3
  Points normals;             ///< N x 3, unit, oriented like the triangles they came from
  Eigen::VectorXi face_ids;   ///< N; face of the source triangle (0 for mesh input)
  Eigen::VectorXi triangle_ids;  ///< N; source triangle index
  std::size_t size() const { return static_cast<std::size_t>(points.rows()); }
};

}  // namespace fe
