// Shared test helpers.
#pragma once

#include "featureextract/mesh.h"

#include <gtest/gtest.h>

#include <string>

namespace fe_test {

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
