// Reading reference and target shapes (issue: Input). B-rep files are tessellated with OpenCASCADE's
// BRepMesh; faces are numbered 1..n in TopExp::MapShapes(shape, TopAbs_FACE) order (FreeCAD's FaceN).
#pragma once

#include "featureextract/mesh.h"

#include <string>

namespace fe {

struct TessellationOptions {
  /// Linear deflection of BRepMesh as a fraction of the shape's bounding-box diagonal.
  double relative_deflection = 0.002;
  /// If > 0, an absolute linear deflection in model units; the smaller of the two is used.
  double absolute_deflection = 0.0;
  /// Angular deflection in radians.
  double angular_deflection = 0.25;
  /// STEP, IGES and BREP are read and tessellated in a child process, which is stopped after this
  /// many seconds: a corrupt file can neither crash the caller nor hang it. < 0 (default): 20 s plus
  /// 10 s per MB of input, several times what a sound file takes (exceeded: InputError, a bad file);
  /// > 0: the caller's own limit (exceeded: TimeLimitExceeded); 0: no limit.
  double time_limit = -1.0;
};

/// Tessellation options for a target searched for a feature of size L (its bounding-box diagonal):
/// the deflection is bounded by the feature's scale, not only the target's own size.
inline TessellationOptions tessellation_for_feature(double feature_size, TessellationOptions o = {}) {
  o.absolute_deflection = o.relative_deflection * feature_size;
  return o;
}

/// Reads STEP (.step/.stp), IGES (.iges/.igs), BREP (.brep/.brp), STL (ascii and binary), OBJ or PLY
/// (ascii, binary little/big endian). Throws InputError with "PATH: problem" on any failure:
/// missing, empty, truncated, garbage, non-finite coordinates, no triangles left.
/// Zero-area triangles are dropped and counted in `dropped_degenerate`.
TriangleMesh read_shape(const std::string& path, const TessellationOptions& options = {});

/// Tessellates a B-rep given as OpenCASCADE's text format (Part.Shape.exportBrepToString()).
TriangleMesh read_brep_string(const std::string& brep, const TessellationOptions& options = {},
                              const std::string& name = "<brep string>");

/// Checks a mesh given as arrays (bindings, generated data): indices in range, finite coordinates.
/// Drops zero-area triangles and orients triangles consistently (orient_consistently). Throws
/// InputError naming `mesh.source`.
void validate_mesh(TriangleMesh& mesh);

/// Makes triangle orientation consistent across shared edges (vertices welded by position), choosing
/// for each connected piece the orientation most of its area already has. Needed because a STEP
/// compound of faces cut from a solid loses the faces' orientation, and meshes may mix windings.
/// Returns the number of triangles flipped.
std::size_t orient_consistently(TriangleMesh& mesh);

/// Writes a binary or ascii STL (used by generators and tests).
void write_stl(const TriangleMesh& mesh, const std::string& path, bool binary = true);

/// Lower-case file extension without the dot ("stp"), or "" if none.
std::string file_extension(const std::string& path);

}  // namespace fe
