// libFuzzer targets for every reader of user input (issue 10). One source, compiled once per kind
// (FE_FUZZ_KIND): the input bytes become a file of that kind, read as the CLI reads it. Bad input must
// end in the documented error (InputError; std::invalid_argument for parameters): any other
// exception, a crash, a sanitizer report or a run past libFuzzer's -timeout is a finding.
#include "featureextract/femesh.h"
#include "featureextract/io.h"
#include "featureextract/params.h"
#include "featureextract/transfer.h"

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <unistd.h>

#ifndef FE_FUZZ_KIND
#error "define FE_FUZZ_KIND: stl obj ply step iges brep inp msh feature params"
#endif
#define FE_STR2(x) #x
#define FE_STR(x) FE_STR2(x)

namespace {

const std::string kind = FE_STR(FE_FUZZ_KIND);

// A private folder per fuzzing process (libFuzzer's -jobs/-fork run several).
const std::string& work_dir() {
  static const std::string dir = [] {
    const char* base = std::getenv("FE_FUZZ_TMP");
    std::string d = std::string(base ? base : "/tmp") + "/fe_fuzz_" + kind + "_" + std::to_string(::getpid());
    std::filesystem::create_directories(d);
    return d;
  }();
  return dir;
}

void write_file(const std::string& path, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

// A feature folder whose feature.json is the input; the files it may name are there, small.
std::string feature_dir() {
  static const std::string dir = [] {
    const std::string d = work_dir() + "/feature";
    std::filesystem::create_directories(d);
    const char* src = std::getenv("FE_FUZZ_FEATURE");  // a valid feature folder to borrow geometry and mesh from
    if (src)
      for (const auto& e : std::filesystem::directory_iterator(src))
        if (e.path().filename() != "feature.json")
          std::filesystem::copy_file(e.path(), d + "/" + e.path().filename().string(), std::filesystem::copy_options::overwrite_existing);
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    if (kind == "params") {
      fe::params_from_json(std::string(reinterpret_cast<const char*>(data), size));
    } else if (kind == "feature") {
      const std::string dir = feature_dir();
      write_file(dir + "/feature.json", data, size);
      fe::read_feature(dir);
    } else if (kind == "inp" || kind == "msh") {
      const std::string path = work_dir() + "/input." + kind;
      write_file(path, data, size);
      fe::read_fe_mesh(path);
    } else {
      const std::string path = work_dir() + "/input." + kind;
      write_file(path, data, size);
      fe::TessellationOptions o;
      o.time_limit = 2;  // a corrupt CAD file that keeps OpenCASCADE busy is stopped (the CLI default: 20 s)
      fe::read_shape(path, o);
    }
  } catch (const fe::InputError&) {
  } catch (const fe::TimeLimitExceeded&) {  // the 2 s limit above, a caller's limit: a hang stopped
  } catch (const std::invalid_argument& e) {
    if (kind != "params") throw;  // only parameters report bad values this way
  }
  return 0;
}
