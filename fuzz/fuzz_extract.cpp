// libFuzzer target for the whole extraction on small shapes (issue 10): steps 1-6 (sampling, normals,
// shape index, SHOT, pairs, clusters, RANSAC, refinement, coverage) under ASan + UBSan, on meshes a
// mutation has bent, torn, flattened or emptied.
//
// The input is a binary or ascii STL, read as the CLI reads it. Its first byte picks its role (binary
// STL headers are free text): even, it is the target and the reference is FE_FUZZ_REFERENCE; odd
// (ascii STL's "solid" starts with 's', odd), it is the reference and the target is FE_FUZZ_TARGET.
// Both files are written by fuzz/make_corpus.py (a rib picked as faces, a plate with two ribs).
//
// The documented outcomes are a result, an InputError ("no distinctive key points", a degenerate
// mesh, ...) or TimeLimitExceeded (the run's 20 s limit, checked at every progress report, as a user's
// --time-limit is). Anything else is a finding: another exception, a crash, a sanitizer report, or a run
// that does not stop at its limit (run.sh gives libFuzzer -timeout=30).
#include "featureextract/extract.h"
#include "featureextract/io.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <unistd.h>

namespace {

const std::string& work_dir() {
  static const std::string dir = [] {
    const char* base = std::getenv("FE_FUZZ_TMP");
    std::string d = std::string(base ? base : "/tmp") + "/fe_fuzz_extract_" + std::to_string(::getpid());
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

// The fixed partner, read once from the file the variable names.
const fe::TriangleMesh& fixed_mesh(const std::string& variable) {
  static std::map<std::string, fe::TriangleMesh> meshes;
  auto it = meshes.find(variable);
  if (it == meshes.end()) {
    const char* path = std::getenv(variable.c_str());
    if (!path) {
      std::fprintf(stderr, "fuzz_extract: set %s (fuzz/run.sh does)\n", variable.c_str());
      std::abort();
    }
    it = meshes.emplace(variable, fe::read_shape(path)).first;
  }
  return it->second;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const bool input_is_target = (data[0] & 1) == 0;
  const fe::TriangleMesh& fixed = fixed_mesh(input_is_target ? "FE_FUZZ_REFERENCE" : "FE_FUZZ_TARGET");
  const std::string path = work_dir() + "/input.stl";
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  // Every stage runs, with fewer samples and RANSAC iterations than the defaults so that an
  // instrumented run takes seconds. The dense samples are capped (max_dense_points: both shapes are described coarser,
  // with a warning) as a user's huge target is, so a mutation that stretches the surface is bounded.
  fe::Params p;
  p.threads = 1;
  p.time_limit = 20;
  p.dense_spacing = 0.025;
  p.sparse_spacing = 0.06;
  p.ransac_max_iterations = 300;
  p.ransac_patience = 100;
  p.refine_iterations = 5;
  p.max_dense_points = 20000;
  try {
    const fe::TriangleMesh input = fe::read_shape(path);
    const fe::Result r = input_is_target ? fe::extract(fixed, input, p) : fe::extract(input, fixed, p);
    (void)r;
  } catch (const fe::InputError&) {
  } catch (const fe::TimeLimitExceeded&) {  // stopped by its limit: bounded, as promised
  }
  // Cancelled, std::invalid_argument, anything else: uncaught, a finding
  return 0;
}
