// One FE mesh of the whole part (issue 12): every found instance carries its feature's mesh (a
// "patch"), the faces no instance covers are meshed by gmsh, run as a separate program
// (core/mesher/fe_gmsh_rest.py), on the patches' border nodes, so that the result is conforming.
// This file: the patches, the job for the mesher, the assembly of its answer with the patches, the
// conformity checks and a CalculiX static analysis deck. Eigen and std only.
#pragma once

#include "featureextract/femesh.h"

#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

namespace fe {

/// A feature's mesh placed on one instance.
struct PartPatch {
  FeMesh mesh;             ///< transferred mesh (shell elements)
  std::vector<int> faces;  ///< 1-based target FaceN the instance covers
  std::string name;        ///< set prefix, e.g. "SCREW_BOSS_2"
  double score = 0;        ///< the match's score (overlaps: the better one stays)
  std::string feature;     ///< feature name, as in feature.json
  /// node sets of the feature that carry a rigid bolt connection (feature.json "analysis")
  std::vector<std::string> rigid_sets;
  std::string spec_json;   ///< the specification, mapped onto this instance (transfer_mesh's spec_json)
  /// scaled Jacobian of each element in the feature's own mesh (same order as mesh's elements; empty:
  /// unknown): the quality goal is judged against it (an element already poor in the reference is not
  /// the placement's fault)
  std::vector<double> reference_scaled_jacobian;
};

/// "screw boss" -> "SCREW_BOSS": upper case, anything but letters and digits becomes '_', runs of '_'
/// merged; empty -> "FEATURE".
std::string set_name(const std::string& text);

/// 0-based nodes on the free edges of the mesh's shell elements (edges used by one element), sorted.
std::vector<int> border_nodes(const FeMesh& m);

/// The faces a placed patch's mesh covers. The extraction lists every face the mapped reference
/// covers half of, which can be a face the feature's mesh only borders (CTC-02: a lug's root fillet,
/// beside the top face the mesh lies on), and the mesher leaves every listed face to the patch: such a
/// face would be meshed by no one. Here a listed face keeps its claim if at least min_share of its
/// area (points about a median edge h of the patch apart) lies within the mesher's reach of the
/// patch's elements (1.5 h: the distance within which the mesher puts a patch node onto a face, so a
/// fit a little off still counts; a face the patch only borders counts its strip along the border).
/// The others are dropped from p.faces, and the elements lying on them (nearest a dropped face, and
/// their centroid more than h / 2 from the kept faces) are removed, with the nodes no element uses
/// any more, p.reference_scaled_jacobian kept in step. An element that only reaches over a kept face's
/// edge stays: the mesher puts its border nodes onto that edge. A patch without faces (a mesh-only
/// target) is left as it is.
struct ClaimReport {
  std::vector<int> dropped_faces;    ///< 1-based FaceN taken out of the claim
  std::size_t removed_elements = 0;  ///< patch elements that lay on them
};
ClaimReport claim_covered_faces(PartPatch& p, const TriangleMesh& part, double min_share = 0.5);

/// Keeps the elements with keep[e] != 0 (global index, blocks in order) and the nodes they use;
/// element and node sets are renumbered, and emptied members dropped.
void keep_elements(FeMesh& m, const std::vector<char>& keep);

/// Removes the patches that share a face with a better-scoring patch (ties: the earlier). Returns one
/// line per removed patch, naming both.
std::vector<std::string> resolve_overlaps(std::vector<PartPatch>& patches);

/// The mesher's job (JSON, see fe_gmsh_rest.py): the part, its face count, the element size of the
/// rest, and per patch its faces, nodes (key = index in the assembled node array), border nodes and
/// the distance within which a node is put onto the B-rep (tolerance_factor x median edge length), and
/// the nodes of its rigid sets. plain: gmsh meshes the whole part, the patches only say where the
/// instances are (the support is chosen away from them, a rigid set becomes the nodes of the face its
/// patch set lies on): the mesh without feature rules that the analysis is compared with.
/// face_centroids (FaceN - 1 -> centroid of its triangles): the mesher checks that its faces are the
/// core's, face by face.
std::string part_mesh_job(const std::string& part_path, int part_faces, double size, const std::vector<PartPatch>& patches,
                          bool plain = false, double tolerance_factor = 1.5,
                          const std::vector<Eigen::Vector3d>& face_centroids = {});

struct PartMeshReport {
  std::size_t patches = 0, patch_nodes = 0, patch_elements = 0, rest_nodes = 0, rest_elements = 0;
  std::size_t joined_nodes = 0;          ///< rest nodes that are patch border nodes
  std::size_t moved_nodes = 0;           ///< patch nodes put onto the B-rep by the mesher
  std::size_t border_nodes_not_joined = 0;  ///< patch border nodes left out of the rest's mesh
  std::size_t duplicate_nodes = 0;       ///< distinct nodes closer than 1e-9 x part size to another
  std::size_t free_edges = 0;            ///< edges of one element (a closed part's surface has none)
  std::size_t free_edges_at_patches = 0; ///< ... of those, on a patch's elements
  int fixed_face = 0;                    ///< support face suggested by the mesher (largest face of the
                                         ///< rest with no covered neighbour)
  std::string mesher_report;             ///< the mesher's own report (JSON object)
};

/// Joins the patches and the mesher's answer (rest_json, fe_gmsh_rest.py's OUT.json) into one mesh:
/// patch nodes first (moved onto the B-rep where the mesher says), then the rest's nodes; the
/// patches' elements with their sets renamed NAME_SET, an element set NAME per patch, the rest's
/// triangles (S3) in element set PART_REST, node set FIXED on the suggested support face (and, for a
/// plain mesh, the rigid sets on their faces). Patches of a plain mesh: pass none. Throws
/// InputError("fe_gmsh_rest: ...") for an answer that does not fit the patches.
FeMesh assemble_part_mesh(const std::vector<PartPatch>& patches, const std::string& rest_json, PartMeshReport* report = nullptr);

/// Quality repair of the placed patches (issue 12, item 2): nodes of patch elements whose scaled
/// Jacobian is below min_scaled_jacobian (the worse of it against the element's own normal and
/// against the mean normal of its neighbours), other than `locked` ones (border and joined nodes),
/// move on `surface` (the part's triangulation) to where the worst of the node's elements is best:
/// first toward the mean of their neighbours (the whole way, half, a quarter), then by a pattern
/// search in the tangent plane. A move is kept only if it betters that worst element and keeps the
/// node's edges on the part (an edge's middle at most max(1 %, 1.25 x before) of its length off the
/// surface: no sharp edge of the part is rounded off). Up to `passes` rounds. The patch elements are
/// the first patch_elements of m. Nodes in on_circles keep their angle about their axis (the rule
/// nodes_on_circles holds through the repair).
struct RepairReport {
  std::size_t inverted_before = 0, inverted_after = 0, poor_before = 0, poor_after = 0, moved_nodes = 0;
  int passes = 0;
};
/// Nodes under a nodes_on_circles rule: a move keeps each one's angle about the axis.
struct NodeAxis {
  Eigen::Vector3d point = Eigen::Vector3d::Zero(), direction = Eigen::Vector3d::UnitZ();
  std::vector<int> nodes;
};
RepairReport repair_patches(FeMesh& m, std::size_t patch_elements, const TriangleMesh& surface, const std::vector<int>& locked,
                            double min_scaled_jacobian = 0.2, int passes = 20, const std::vector<NodeAxis>& on_circles = {});

/// The feature's meshing rules (feature.json "rules", with the axis and "transform" the transfer
/// mapped) checked on a placed patch; a JSON array, one object per rule with "ok" (null: no check):
/// nodes_on_circles (every node off the axis within 1 degree of start + k x step around the mapped
/// axis, moved to pass through the patch's centroid), element_size (median edge within 0.7-1.3 of size x the instance's scale), quad_dominant
/// (at least half the elements quads).
std::string check_rules(const FeMesh& patch, const std::string& spec_json);

/// The specification's "transition_zone" rule ({"rule": "transition_zone", "width": W}: around the
/// instance the rest's element size grows linearly from the patch's median edge to rest_size over W
/// times the instance's scale; part_mesh_job passes it to the mesher) checked on the whole mesh: the
/// rest's shell elements (after the first patch_elements) whose centroid lies within the width of
/// the patch's border nodes, their mean edge over the size the zone asks at that distance. JSON
/// object (elements, median_ratio, max_ratio, share_within_1.5, ok: at least 90 % within 1.5x), or
/// "" when the specification has no such rule.
std::string check_transition(const FeMesh& whole, std::size_t patch_elements, const FeMesh& patch, const std::string& spec_json,
                             double rest_size);

/// Free edges (edges of exactly one shell element) and pairs of distinct nodes closer than tolerance.
void conformity(const FeMesh& m, double tolerance, std::size_t* free_edges, std::size_t* duplicate_nodes,
                std::vector<int>* free_edge_elements = nullptr);

/// The job that fills a closed surface mesh with tetrahedra (fe_gmsh_rest.py's fill): node ids are
/// rows + 1, quads are cut into two triangles across the shorter diagonal.
std::string fill_job(const FeMesh& surface, double size);

/// The solid mesh from the fill's answer: the surface's nodes (same rows, same node sets), then the
/// inner ones; 4-node tetrahedra (C3D4, positive volume) in element set PART_SOLID. Throws InputError
/// ("fe_gmsh_rest: ...") for an answer that does not fit the surface.
FeMesh solid_from_fill(const FeMesh& surface, const std::string& fill_json);

/// The solid's tetrahedra made quadratic (C3D10, to_quadratic in femesh.h): the edges of the surface
/// mesh's elements are its surface edges (their middles join the node sets holding both ends: FIXED,
/// the bolt sets), and their middles go onto the part's surface `part` (its triangulation, nearest
/// point) unless that is farther than a quarter of the edge (another wall) or folds a tetrahedron.
/// `on_part` receives how many middles were moved onto the part.
///
/// With `onto_faces` (a part read from a B-rep), each middle's foot on the triangulation is then moved
/// onto the exact B-rep face of its triangle: onto_faces(points, faces) moves points.row(i) onto
/// FaceN faces[i] and leaves a row it cannot place as it is (mesh-part asks the mesher, which holds
/// the B-rep). The same quarter-edge and fold rules apply. `on_brep` receives how many middles the
/// projection moved (a triangulation's chord sags up to its deflection; the B-rep does not).
using FaceProjector = std::function<void(Points& points, const std::vector<int>& faces)>;
FeMesh quadratic_solid(const FeMesh& solid, const FeMesh& surface, const TriangleMesh& part, std::size_t* on_part = nullptr,
                       const FaceProjector& onto_faces = {}, std::size_t* on_brep = nullptr);

/// Node ids 1..N in reverse Cuthill-McKee order of the element graph (Boost.Graph), rows and sets
/// unchanged, deterministic. CalculiX numbers its equations in node id order; SPOOLES's ordering
/// stopped ("fatal error in GPart_makeYCmap", exit 255) on a shell model of the example plate
/// numbered patch by patch (with the fits of an experiment), and solved the same mesh in this order
/// (and in a random one): the failure depends on the numbering, so this lowers its odds, no more.
void number_nodes_for_solver(FeMesh& m);

/// A linear static analysis for CalculiX: the mesh (*INCLUDE of mesh_file), an isotropic material,
/// a shell section of the given thickness on each of section_sets (together: every element), the node set `fixed_set` held in all six
/// degrees of freedom, and per rigid set a reference node at the set's centroid, joined by *RIGID
/// BODY, loaded by `force` along `direction`. Displacements (*NODE PRINT, .dat) and stresses (*EL
/// FILE, .frd) are written.
struct StaticAnalysis {
  double thickness = 1.0, young = 210000.0, poisson = 0.3;
  std::string fixed_set = "FIXED";
  std::vector<std::string> section_sets;
  bool solid = false;  ///< *SOLID SECTION (no thickness), supports hold 3 degrees of freedom
  std::vector<std::string> rigid_sets;
  double force = 100.0;
  Eigen::Vector3d direction{0, 0, -1};
};
void write_ccx_static(const FeMesh& m, const std::string& mesh_file, const StaticAnalysis& a, const std::string& path);

}  // namespace fe
