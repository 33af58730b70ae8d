// Shared test helpers.
#pragma once

#include "featureextract/mesh.h"
#include "featureextract/result.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <string>

namespace fe_test {

// The generated models' folder: FE_MODELS (set by CTest), else ./models.
inline std::string models() {
  const char* d = std::getenv("FE_MODELS");
  return d ? d : "models";
}

// The generator's ground truth (models()/truth.json).
inline nlohmann::json truth() {
  std::ifstream in(models() + "/truth.json");
  EXPECT_TRUE(in.good()) << "run fe_make_models first";
  return nlohmann::json::parse(in);
}

// Index of the match whose center is within `tol` (in x and y) of (x, y), or -1.
inline int match_near(const fe::Result& r, double x, double y, double tol) {
  for (std::size_t i = 0; i < r.matches.size(); ++i)
    if (std::abs(r.matches[i].center.x() - x) < tol && std::abs(r.matches[i].center.y() - y) < tol) return static_cast<int>(i);
  return -1;
}

// Expects read(path) to throw InputError whose message starts with "PATH: ", is one line and
// contains `fragment`.
template <class Read>
void expect_one_line_error(const std::string& path, const std::string& fragment, Read read) {
  try {
    read(path);
    FAIL() << "no error for " << path;
  } catch (const fe::InputError& e) {
    const std::string msg = e.what();
    EXPECT_EQ(msg.rfind(path + ": ", 0), 0u) << msg;
    EXPECT_EQ(msg.find('\n'), std::string::npos) << msg;
    EXPECT_NE(msg.find(fragment), std::string::npos) << msg;
  }
}

}  // namespace fe_test
