// Internal: a whole file as text, with the project's one-line errors ("PATH: problem").
#pragma once

#include "featureextract/mesh.h"

#include <fstream>
#include <sstream>
#include <string>

namespace fe {

/// The file's bytes; InputError if it cannot be opened or holds nothing but white space.
inline std::string read_file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open file (missing or unreadable)");
  std::ostringstream ss;
  ss << in.rdbuf();
  std::string data = ss.str();
  if (data.find_first_not_of(" \t\r\n") == std::string::npos) throw InputError(path + ": file is empty");
  return data;
}

}  // namespace fe
