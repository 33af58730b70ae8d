// Internal: a shape as regions bounded by sharp edges, and how they meet (issue 9, machined
// features). The paper's key points see a pocket, a slot or a step as planes and creases of the
// same few kinds everywhere; what tells one pocket from another place is how its faces meet: which
// face borders which, along a convex or a concave edge, and where three of them meet. topology.h
// matches that structure of a reference on a target, whatever the instance's proportions.
//
// Regions are computed from the triangles alone, the same way for a B-rep tessellation and for an
// STL: triangles joined across edges where the surface turns by less than the crease angle (and,
// for B-rep input, all the triangles of one face), so that a picked-face reference, a box-cut solid
// and a clipped STL region of one feature give the same regions.
#pragma once

#include "featureextract/mesh.h"

#include <Eigen/Core>
#include <array>
#include <vector>

namespace fe {

/// Vertices welded by position: rows of `v` closer than `tolerance` share an id (ids 0..n-1, in
/// order of first appearance). Their positions (the first of each) in *welded when asked.
std::vector<int> weld_vertices(const Points& v, double tolerance, Points* welded = nullptr);

struct RegionGraph {
  struct Region {
    bool planar = false;
    Eigen::Vector3d normal = Eigen::Vector3d::Zero();    ///< area-weighted mean normal (unit)
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< area centroid
    double area = 0;
    bool open = false;  ///< part of its border has no neighbouring triangle (the border of an open shell)
    bool cut = false;   ///< part of that border lies where the reference was cut (mark_cut): context, not feature
    std::vector<int> border;  ///< welded vertices on its border, sorted
  };
  /// Two regions meeting along an edge.
  struct Contact {
    int other = -1;
    double angle = 0;   ///< mean dihedral angle along it (radians), > 0 convex, < 0 concave
    double length = 0;
  };
  /// A welded vertex on some region's border.
  struct Vertex {
    Eigen::Vector3d point = Eigen::Vector3d::Zero();
    std::vector<int> regions;  ///< regions of the triangles around it, sorted
    std::vector<int> turning;  ///< regions whose border turns here (a corner of that region), sorted
    bool open = false;         ///< on the shell's open border
    bool on_cut = false;       ///< on an open border edge where the reference was cut
  };

  std::vector<Region> regions;
  std::vector<std::vector<Contact>> contacts;  ///< per region, sorted by other
  std::vector<Vertex> vertices;                ///< border vertices only
  std::vector<int> triangle_region;            ///< per triangle (-1: degenerate)
  std::vector<std::array<int, 2>> open_edges;  ///< open border edges, as rows of `vertices`, with...
  std::vector<int> open_edge_region;           ///< ...the region each belongs to

  /// The contact between regions a and b, or nullptr.
  const Contact* contact(int a, int b) const;
  std::size_t size() const { return regions.size(); }
};

/// The regions of a mesh (see above). `crease_degrees`: adjacent triangles whose normals differ by
/// more are in different regions (unless they are of one B-rep face). The two walls of an MFCAD
/// "2 sides" step meet at 18 degrees; tangent faces (fillets) meet at 0.
RegionGraph region_graph(const TriangleMesh& mesh, double crease_degrees = 10.0);

/// Marks as cut the regions with an open border edge lying (within `tolerance`) in a plane of the
/// box lo..hi on a side that was cut (-x, +x, -y, +y, -z, +z), and those edges' vertices.
void mark_cut(RegionGraph& g, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const std::array<bool, 6>& cut_sides,
              double tolerance);

}  // namespace fe
