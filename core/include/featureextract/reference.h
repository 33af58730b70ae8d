// References as users make them (issue 9): a solid cut out of a part with a box carries cut faces
// that do not exist on the part at that place; a feature may occur as its own mirror image. These
// functions prepare a reference mesh for the search; extract() calls them, and they are public so
// that each can be tested alone.
#pragma once

#include "featureextract/mesh.h"

#include <Eigen/Core>
#include <array>
#include <vector>

namespace fe {

/// What detect_cut_faces found.
struct CutFaces {
  bool closed = false;                 ///< the reference is a closed surface (a solid, not picked faces)
  std::vector<char> cut_triangle;      ///< per triangle: 1 if it lies on a cut face
  std::vector<int> faces;              ///< 1-based B-rep faces treated as cut (empty for mesh input)
  std::size_t triangles = 0;           ///< number of cut triangles
  /// Sides of the bounding box (-x, +x, -y, +y, -z, +z) where the reference was cut: they hold cut
  /// faces (closed reference), or, for an open mesh region clipped out of a mesh with a box, at
  /// least a tenth of its border runs along them (`triangles` is then 0: nothing is left out).
  std::array<bool, 6> cut_sides{};
  /// For an open mesh region clipped out of a mesh with a box: its planar faces in two opposite,
  /// unclipped planes of its box, each reaching every clipped side around it (at least two). The
  /// region passes through between them, like a hole across a wall whose box reached past both of
  /// the wall's faces: they are the part's own faces, left out of the search like a box cut's own
  /// faces (searched_reference), so that the faces ending on them are whole there. Per triangle, 1
  /// for such a face (empty for a closed reference or picked faces).
  std::vector<char> own_triangle;
  std::size_t own_triangles = 0;  ///< their number
  bool any_side_cut() const {
    for (bool s : cut_sides)
      if (s) return true;
    return false;
  }
};

/// Cut faces of a reference that was cut out of a part with a box (the paper's own way of making a
/// reference): only a closed reference can have them (faces picked from a solid form an open shell).
/// A cut face is a planar region lying in one of the planes of the reference's bounding box, facing
/// out of it, that reaches at least one other bounding-box plane: the box sliced through material
/// that goes on beyond the box. A real face that happens to lie on a box plane inside the box (a rib's
/// top) reaches no other plane and is kept. Regions are B-rep faces, or for mesh input connected
/// coplanar triangles. `tolerance` is relative to the bounding-box diagonal.
CutFaces detect_cut_faces(const TriangleMesh& mesh, double tolerance = 2e-3);

/// The cut faces of a box-cut reference that are the part's own faces: where the reference sits on
/// `target` unmoved (it was cut out of that very part: at least 90 % of its other faces' samples,
/// `spacing` apart, lie on the target's surface with agreeing normals), a cut face (a B-rep face, or
/// a triangle of mesh input) at least 80 % of whose samples lie on the target's surface too is one
/// of the part's own faces that happens to lie on the box (the box reached past the part there: a
/// corner step's floor meets the part's side faces and top on the box). Per triangle of `reference`,
/// 1 for such a face; all 0 when the reference does not sit on the target unmoved.
std::vector<char> cut_faces_on_target(const TriangleMesh& reference, const CutFaces& cut, const TriangleMesh& target, double spacing);

/// `m` placed by H (apply_transform on every vertex; the winding reversed where H mirrors, so that
/// normals stay outward): a reference where one of its matches put it on the target.
TriangleMesh placed_mesh(const TriangleMesh& m, const Eigen::Matrix4d& H);

/// Where a clipped region meets the planes it passes through between (CutFaces::own_triangle): the
/// vertices those planes share with the rest of the region, once each, and in *outward the planes'
/// outward unit normals there. Empty when it has none.
Points through_rims(const TriangleMesh& mesh, const CutFaces& cut, Points* outward);

/// `cut` without the triangles marked in `own` (they are kept as the reference's faces): the count,
/// the B-rep faces and the cut sides again.
CutFaces without_own_faces(const TriangleMesh& reference, const CutFaces& cut, const std::vector<char>& own);

/// Per B-rep face number (0..num_faces): 1 where the face reaches the mesh's open border, the edge
/// where a user stopped picking faces or where a cut face was left out (searched_reference). Such a
/// face may end sooner on an instance: a bolt hole's cylinder picked in a 24 mm plate goes on for
/// as long as the wall it is drilled through. Empty for mesh input (no B-rep faces).
std::vector<char> faces_on_border(const TriangleMesh& mesh);

/// Points along the mesh's open border (edges used by one triangle), at most `step` apart, and the
/// B-rep face of each in *face. Empty for mesh input (no B-rep faces) or a closed mesh.
Points open_border_points(const TriangleMesh& mesh, double step, std::vector<int>* face);

/// The mesh without the triangles marked in `drop` (face numbering kept; unused vertices removed).
TriangleMesh without_triangles(const TriangleMesh& mesh, const std::vector<char>& drop);

/// The mirror image of a mesh through the plane x = center.x() (triangle winding reversed, so that
/// outward normals stay outward), and the 4 x 4 reflection M with mirrored = M * original.
TriangleMesh mirrored_mesh(const TriangleMesh& mesh, const Eigen::Vector3d& center, Eigen::Matrix4d* M);

/// Is a sampled surface its own mirror image? Planes through the centroid normal to each principal
/// axis and to each coordinate axis are tried: symmetric if at least `fraction` of the reflected
/// points lie within `tolerance` of the surface with agreeing normals. A symmetric reference needs
/// no mirrored search (its mirror image is a rotated copy of itself).
bool is_mirror_symmetric(const Points& points, const Points& normals, double tolerance, double fraction = 0.97);

}  // namespace fe
