// The FE-mesh library: containers, element types and the reader dispatch. Formats in inp_read.cpp,
// msh_read.cpp, inp_write.cpp, msh_write.cpp; quality in quality.cpp. Eigen and std only: this library
// needs neither PCL nor OpenCASCADE (core/CMakeLists.txt builds it as fe_femesh).
#include "femesh_detail.h"

namespace fe {

int nodes_per_element(ElementType type) {
  switch (type) {
    case ElementType::Tri3: return 3;
    case ElementType::Quad4: return 4;
    case ElementType::Tet4: return 4;
    case ElementType::Hex8: return 8;
    case ElementType::Tet10: return 10;
  }
  return 0;
}

bool is_shell(ElementType type) { return type == ElementType::Tri3 || type == ElementType::Quad4; }

const char* inp_type_name(ElementType type) {
  switch (type) {
    case ElementType::Tri3: return "S3";
    case ElementType::Quad4: return "S4";
    case ElementType::Tet4: return "C3D4";
    case ElementType::Hex8: return "C3D8";
    case ElementType::Tet10: return "C3D10";
  }
  return "?";
}

std::size_t FeMesh::num_elements() const {
  std::size_t n = 0;
  for (const auto& b : blocks) n += static_cast<std::size_t>(b.conn.rows());
  return n;
}

FeMesh read_fe_mesh(const std::string& path) {
  const auto slash = path.find_last_of("/\\");
  const auto dot = path.find_last_of('.');
  std::string ext = dot == std::string::npos || (slash != std::string::npos && dot < slash) ? std::string() : path.substr(dot + 1);
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == "inp") return femesh_detail::read_inp(path);
  if (ext == "msh") return femesh_detail::read_msh(path);
  femesh_detail::fail(path, "unknown FE mesh file type '." + ext + "' (supported: .inp, .msh)");
}

}  // namespace fe
