// From a found feature to its FE mesh (issue 5): a reference feature folder (geometry, FE mesh,
// meshing specification) and the transfer of its mesh onto each found instance. Eigen and std only.
#pragma once

#include "featureextract/femesh.h"
#include "featureextract/mesh.h"

#include <Eigen/Core>
#include <string>
#include <vector>

namespace fe {

/// A reference feature folder: DIR/feature.json names the geometry (BREP/STEP/mesh) and the FE mesh
/// (.inp or .msh), and holds the meshing specification (element size, rules, named sets).
struct FeatureModel {
  std::string dir, name;
  std::string geometry_path, mesh_path;
  FeMesh mesh;
  std::string spec_json;  ///< feature.json as read
};

/// Reads DIR/feature.json ({"geometry": file, "mesh": file, "name": text, ...}) and the mesh it names.
/// Throws InputError naming the file and the problem.
FeatureModel read_feature(const std::string& dir);

struct TransferOptions {
  /// A mapped node is moved onto the target surface if a foot point lies within this distance, as a
  /// fraction of the reference mesh's bounding-box diagonal times the local scale of H; farther nodes
  /// keep the mapped position (and are counted as unprojected).
  double max_projection = 0.03;
  /// A foot point must lie on a target triangle whose normal is within acos(normal_agreement) of the
  /// node's mapped normal (so a node on a rib's flank does not jump to the opposite flank or the
  /// plate); if no triangle agrees, the nearest one within reach is used.
  double normal_agreement = 0.3;
  /// Only feet on the target's triangles of these B-rep faces (FaceN, sorted); empty: any triangle.
  /// mesh-part gives the faces an instance claims, the ones the rest's mesher puts its nodes on: a node
  /// past them then stops on their edge and the border morph pulls the mesh back inside, where a foot on
  /// a neighbouring face (a lug's root fillet) would fold the outer rows onto that edge later.
  std::vector<int> faces;
};

struct TransferredMesh {
  FeMesh mesh;  ///< nodes mapped by H and moved onto the target; the reference's sets, plus element
                ///< set FE_INVALID when some elements were inverted by the transfer
  std::vector<ElementQuality> before, after;  ///< per element: reference mesh, transferred mesh
  QualitySummary before_summary, after_summary;
  std::size_t projected = 0, unprojected = 0;
  double max_projection_distance = 0;  ///< largest move of a node from H's position onto the surface
  double max_surface_distance = 0;     ///< largest distance of a final node from the target triangles
  std::size_t morphed = 0;             ///< interior nodes moved with the border (a border past the target's
                                       ///< faces spread over the interior; 0 when none was, or it did not help)
  std::vector<long> invalid_elements;  ///< external ids of elements valid before and inverted after
  bool reversed = false;               ///< H is a reflection (a mirrored instance): element node order was
                                       ///< reversed so that shell normals stay outward
  std::string spec_json;               ///< the specification, its axis mapped by H, H added
};

/// Maps the reference mesh's nodes by H (reference -> target, as in a Match), moves them onto the
/// target triangulation (closest point with agreeing normal), and measures element quality before and
/// after; inversion of shells is judged against each element's normal mapped by H.
TransferredMesh transfer_mesh(const FeMesh& reference, const Eigen::Matrix4d& H, const TriangleMesh& target,
                              const TransferOptions& options = {}, const std::string& spec_json = "{}");

/// Closest point to p on triangle (a, b, c).
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c);

}  // namespace fe
