// featureextract: command-line front end of the extraction core.
//   featureextract extract --reference REF --target TGT --output OUT.json [--config PARAMS.json]
//                          [--seed N] [--threads N] [--set NAME=VALUE]... [--quiet]
// Exit codes: 0 done (also when nothing is found), 2 usage error, 3 unreadable or invalid input,
// 4 the output could not be written, 1 internal error.
#include "featureextract/extract.h"
#include "featureextract/io.h"

#include <CLI/CLI.hpp>

#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>

namespace {

std::string param_help() {
  std::ostringstream s;
  s << "\nParameters (set them with --config FILE.json or --set NAME=VALUE; L = reference bounding-box diagonal):\n";
  for (const auto& p : fe::param_table()) {
    s << "  " << p.name << " (" << p.type << (p.unit.empty() ? "" : ", " + p.unit) << ", default " << p.default_value << ")\n"
      << "      " << p.help << "\n";
  }
  s << "\nExit codes: 0 done (also when nothing is found), 2 usage error, 3 unreadable or invalid input,\n"
       "4 output not writable, 1 internal error.\n";
  return s.str();
}

struct Progress {
  bool quiet = false;
  std::string stage;
  double last = -1;
  bool operator()(const std::string& s, double f) {
    if (quiet) return true;
    if (s != stage || f >= last + 0.1 || (f >= 1.0 && last < 1.0)) {
      std::cerr << "featureextract: " << s << " " << static_cast<int>(f * 100 + 0.5) << "%\n";
      stage = s;
      last = f;
    }
    return true;
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"FeatureExtract: find every region of a target CAD part or mesh that is similar to a reference feature\n"
               "(Takashima & Kanai's shape-index + multi-radius SHOT method, RANSAC projective transform)."};
  app.require_subcommand(1);
  app.footer(param_help());
  auto* ex = app.add_subcommand("extract", "find the instances of REF in TGT and write them as JSON");
  std::string ref_path, tgt_path, out_path, config_path;
  std::uint64_t seed = 0;
  int threads = -1;
  bool quiet = false;
  std::vector<std::string> sets;
  ex->add_option("--reference,-r", ref_path, "reference feature: STEP, IGES, BREP, STL, OBJ or PLY")->required();
  ex->add_option("--target,-t", tgt_path, "target part: STEP, IGES, BREP, STL, OBJ or PLY")->required();
  ex->add_option("--output,-o", out_path, "result JSON file (written atomically)")->required();
  ex->add_option("--config,-c", config_path, "JSON object of parameters (see below)");
  auto* seed_opt = ex->add_option("--seed", seed, "seed of sampling and RANSAC (default 1)");
  ex->add_option("--threads", threads, "worker threads (default 0 = all cores)");
  ex->add_option("--set", sets, "override one parameter, NAME=VALUE (repeatable)");
  ex->add_flag("--quiet,-q", quiet, "no progress on stderr");
  ex->footer(param_help());

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    std::cout << app.help() << std::flush;
    return 0;
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    std::cerr << "featureextract: " << e.what() << " (see featureextract extract --help)\n";
    return 2;
  }

  fe::Params params;
  try {
    if (!config_path.empty()) {
      std::ifstream in(config_path);
      if (!in) {
        std::cerr << "featureextract: " << config_path << ": cannot open config file\n";
        return 2;
      }
      std::stringstream ss;
      ss << in.rdbuf();
      params = fe::params_from_json(ss.str());
    }
    for (const std::string& kv : sets) {
      const auto eq = kv.find('=');
      if (eq == std::string::npos) throw std::invalid_argument("--set expects NAME=VALUE, got '" + kv + "'");
      params = fe::params_from_json("{\"" + kv.substr(0, eq) + "\": " + kv.substr(eq + 1) + "}", params);
    }
    if (*seed_opt) params.seed = seed;
    if (threads >= 0) params.threads = threads;
    params.validate();
  } catch (const std::invalid_argument& e) {
    std::cerr << "featureextract: " << (config_path.empty() ? std::string("--set") : config_path) << ": " << e.what() << "\n";
    return 2;
  }

  Progress progress;
  progress.quiet = quiet;
  fe::Result result;
  try {
    fe::TessellationOptions to;
    const fe::TriangleMesh ref = fe::read_shape(ref_path, to);
    const fe::TriangleMesh tgt = fe::read_shape(tgt_path, fe::tessellation_for_feature(ref.diagonal(), to));
    for (const fe::TriangleMesh* m : {&ref, &tgt})
      if (m->dropped_degenerate > 0 && !m->from_brep() && !quiet)  // BRepMesh's own slivers are routine
        std::cerr << "featureextract: " << m->source << ": warning: " << m->dropped_degenerate << " zero-area triangles ignored\n";
    result = fe::extract(ref, tgt, params, std::ref(progress));
  } catch (const fe::InputError& e) {
    std::cerr << "featureextract: " << e.what() << "\n";
    return 3;
  } catch (const std::exception& e) {
    std::cerr << "featureextract: internal error: " << e.what() << "\n";
    return 1;
  }
  if (!quiet) {
    for (const auto& w : result.warnings) std::cerr << "featureextract: warning: " << w << "\n";
    std::cerr << "featureextract: " << result.matches.size() << " instance(s) found\n";
  }
  const std::string tmp = out_path + ".tmp";
  {
    std::string text;
    try {
      text = fe::result_to_json(result);
    } catch (const std::exception& e) {
      std::cerr << "featureextract: " << out_path << ": cannot encode the result: " << e.what() << "\n";
      return 1;
    }
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text << "\n";
    out.close();
    if (!out) {
      std::cerr << "featureextract: " << out_path << ": cannot write output\n";
      std::remove(tmp.c_str());
      return 4;
    }
  }
  if (std::rename(tmp.c_str(), out_path.c_str()) != 0) {
    std::cerr << "featureextract: " << out_path << ": cannot write output\n";
    std::remove(tmp.c_str());
    return 4;
  }
  return 0;
}
