// Finite-element meshes: reading and writing Abaqus/CalculiX .inp and gmsh .msh, element quality.
// A found feature receives a reference FE mesh that is mapped onto the target; these are the
// containers, the file formats and the checks (inverted / distorted elements) for that mesh.
// Linear elements (3- and 4-node shells, 4-node tetrahedra, 8-node hexahedra) and 10-node tetrahedra.
// Eigen and std only (see README, "Layout").
#pragma once

#include "featureextract/mesh.h"

#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace fe {

/// Element types. Abaqus/CalculiX: S3 / S4 (shells), C3D4 / C3D8 / C3D10 (solids); gmsh element
/// types 2, 3, 4, 5, 11. Node order is the common one of both formats (quad and hex bottom face
/// counter-clockwise; tet/hex with positive volume when (x1-x0) x (x2-x0) . (x3-x0) > 0 resp. the
/// top face 4-7 above the bottom face 0-3). Tet10 is Abaqus's: corners 0-3, then the middles of the
/// edges 01, 12, 20, 03, 13, 23 (gmsh lists 23 before 13; the .msh reader and writer swap them).
enum class ElementType { Tri3, Quad4, Tet4, Hex8, Tet10 };

/// Number of nodes of an element type (3, 4, 4, 8, 10).
int nodes_per_element(ElementType type);
/// True for Tri3 and Quad4.
bool is_shell(ElementType type);
/// "S3", "S4", "C3D4", "C3D8", "C3D10".
const char* inp_type_name(ElementType type);

/// Elements of one type.
struct ElementBlock {
  ElementType type = ElementType::Tri3;
  std::vector<long> ids;  ///< external element ids, one per row of conn
  Eigen::Matrix<int, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> conn;  ///< rows x nodes_per_element, 0-based node indices
  std::string elset;      ///< the *ELEMENT ELSET= name or the gmsh physical name; may be empty
};

struct FeMesh {
  std::vector<long> node_ids;  ///< external node ids, as in the file (one per row of nodes)
  Points nodes;                ///< N x 3
  std::vector<ElementBlock> blocks;
  /// name -> 0-based node indices, sorted, unique.
  std::map<std::string, std::vector<int>> node_sets;
  /// name -> global 0-based element indices (blocks in order), sorted, unique. Includes the sets
  /// named by *ELEMENT, ELSET= (resp. the blocks' gmsh physical groups).
  std::map<std::string, std::vector<int>> element_sets;

  std::size_t num_elements() const;
};

/// Reads by extension: .inp (Abaqus/CalculiX) or .msh (gmsh ASCII 2.x and 4.1).
/// .inp: keywords case-insensitive, "**" comments, *INCLUDE (INPUT= relative to the file), *NODE
/// (NSET=), *ELEMENT (TYPE=, ELSET=; records may continue over several lines), *NSET / *ELSET (ids,
/// names of earlier sets, GENERATE); other keywords and their data are skipped. Set names are matched
/// case-insensitively (the first spelling is kept). Element types are mapped to the five kinds
/// (e.g. S4R -> Quad4, C3D8R -> Hex8, C3D10M -> Tet10), so writing back gives S3/S4/C3D4/C3D8/C3D10;
/// any other type (S8R, C3D20, beams and trusses such as B31 / T3D2, ...) is an InputError naming it.
/// .msh: elements of types 2-5 and 11; point (15) and 2-node line (1) elements are not elements of the
/// FeMesh but their nodes go into node sets named after their physical groups. Physical groups
/// without a name are called "Physical<dim>D_<tag>"; every named group gives a set (dimension 0/1: node
/// set, 2/3: element set), possibly empty. Blocks are formed per (element type, first physical group),
/// which is also the block's elset. An element msh 2 writes once per physical group is read once.
/// Binary .msh and versions other than 2.x / 4.1 are refused.
/// Throws InputError "PATH: problem" (one line, with the line number where it applies) for missing,
/// empty, truncated or garbage files, unsupported element types (named), references to missing
/// nodes / elements, duplicate ids and non-finite coordinates.
FeMesh read_fe_mesh(const std::string& path);

/// Abaqus/CalculiX input: *NODE, *ELEMENT (TYPE=S3/S4/C3D4/C3D8, ELSET= the block's elset),
/// *NSET and *ELSET (16 ids per line; an element set that is exactly the union of the blocks carrying
/// its name is not repeated). Coordinates are written as the shortest text that reads back exactly,
/// unless that is longer than the 20 characters CalculiX reads (e.g. -9.358640446443431e-17): then with
/// 13 significant digits.
/// Empty node_ids / block ids are replaced by 1-based positions. Throws std::runtime_error if the
/// file cannot be written, std::invalid_argument for an inconsistent mesh.
void write_inp(const FeMesh& m, const std::string& path);

/// gmsh ASCII 4.1. Element sets (and block elsets) become named physical groups of dimension 2
/// (shells) or 3 (solids) on discrete entities grouped by set membership; node sets become named
/// physical groups of dimension 0, one point entity and one point element per member node, so
/// read_fe_mesh gives back the same nodes, elements (ids, connectivity) and sets (blocks may be
/// regrouped: an element without block elset gets its first element set as elset). gmsh itself reads
/// the files. Throws like write_inp.
void write_msh(const FeMesh& m, const std::string& path);

/// Every Tet4 block becomes Tet10 (CalculiX C3D10): one new node at the middle of each tetrahedron
/// edge, shared by the tetrahedra around that edge. A new node joins every node set that holds both
/// ends of its edge, where `on_surface(a, b)` (0-based node indices) says the edge lies on the surface
/// (without it, every edge does): a fixed face or a bolt's hole then fixes and loads its middle nodes
/// too, and a chord through the solid between two nodes of a set does not join it. `place` (optional)
/// moves a surface edge's new node from the straight middle (e.g. onto the curved part); where that
/// leaves a tetrahedron with a non-positive Jacobian at one of its nodes, the node goes back to the
/// straight middle. New nodes take ids after the largest one. Other blocks are kept as they are; a
/// Tet10 block's middles are shared by Tet4 tetrahedra on the same edges (no duplicate middle node).
/// `moved` (optional) receives how many new nodes stayed where `place` put them.
FeMesh to_quadratic(const FeMesh& m, const std::function<bool(int, int)>& on_surface = {},
                    const std::function<Eigen::Vector3d(int, int, const Eigen::Vector3d&)>& place = {},
                    std::size_t* moved = nullptr);

/// Shape quality of one element (Verdict-style definitions).
///  aspect_ratio: Tri3: longest edge / shortest altitude * sqrt(3)/2; Quad4 and Hex8: longest edge /
///    shortest edge; Tet4: longest edge / (2 sqrt(6) inradius) (Verdict). 1 for a perfect element,
///    infinity for a degenerate one.
///  scaled_jacobian: minimum over the corners of the corner Jacobian divided by the product of the
///    corner's edge lengths (Tri3 scaled by 2/sqrt(3), Tet4 by sqrt(2)), so 1 for a perfect element,
///    0 for a degenerate one, negative for an inverted one. Tet10: its corner tetrahedron's value times
///    the smallest ratio of the Jacobian determinant at one of its ten nodes to the straight
///    tetrahedron's (the same as Tet4 for straight edges; smaller, down to negative, as the middle
///    nodes move off the straight middles). Aspect ratio and angles are the corner tetrahedron's. Shells: the corner normal (e1 x e2) is
///    measured along the reference normal if given, else along the element's own normal.
///  min_angle_deg: smallest interior angle of the element's faces (60 for an equilateral
///    triangle and a regular tet, 90 for a square / cube).
///  inverted: some corner Jacobian is negative (scaled_jacobian < 0).
struct ElementQuality {
  double aspect_ratio = 0;
  double scaled_jacobian = 0;
  double min_angle_deg = 0;
  bool inverted = false;
};

/// One entry per element, global element order (blocks in order).
/// reference_normals (optional): num_elements() rows; for a shell, the direction its normal must keep
/// (e.g. its normal before a mapping); a shell whose corner Jacobian points against it gets a negative
/// scaled Jacobian and inverted = true. Rows of solids and zero rows are ignored. Solids: the sign of
/// the corner Jacobian determinants. Throws std::invalid_argument for a wrong number of rows.
std::vector<ElementQuality> element_quality(const FeMesh& m, const Points* reference_normals = nullptr);

/// Unit normal per element, global element order: (x1-x0) x (x2-x0) for Tri3, (x2-x0) x (x3-x1) for
/// Quad4; zero rows for solids and degenerate shells.
Points element_normals(const FeMesh& m);

struct QualitySummary {
  std::size_t elements = 0, inverted = 0;
  double min_scaled_jacobian = std::numeric_limits<double>::quiet_NaN();
  double median_scaled_jacobian = std::numeric_limits<double>::quiet_NaN();
  double max_aspect_ratio = std::numeric_limits<double>::quiet_NaN();
  double median_aspect_ratio = std::numeric_limits<double>::quiet_NaN();
  double min_angle_deg = std::numeric_limits<double>::quiet_NaN();
};

/// Statistics over element_quality(); NaN fields for no elements.
QualitySummary summarize(const std::vector<ElementQuality>& q);

}  // namespace fe
