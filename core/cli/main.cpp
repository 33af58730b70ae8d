// featureextract: command-line front end of the extraction core.
//   featureextract extract --reference REF --target TGT --output OUT.json [--config PARAMS.json]
//                          [--seed N] [--threads N] [--set NAME=VALUE]... [--quiet]
//   featureextract mesh --feature FEATURE_DIR --target TGT --output OUT_DIR [same options]
//       extraction with the feature folder's geometry, then its FE mesh placed on every instance:
//       OUT_DIR/instance_NN.inp, .msh, .feature.json and OUT_DIR/result.json (with a "transfer"
//       entry per match: node projection and element quality before and after)
// Exit codes: 0 done (also when nothing is found), 2 usage error, 3 unreadable or invalid input,
// 4 the output could not be written, 5 stopped by --time-limit, 1 internal error.
#include "featureextract/extract.h"
#include "featureextract/io.h"
#include "featureextract/transfer.h"

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

namespace {

// Messages stay on one line whatever a file name holds: control characters are written escaped.
std::string one_line(const std::string& s) {
  std::string o;
  for (const unsigned char c : s) {
    if (c == '\n') o += "\\n";
    else if (c == '\r') o += "\\r";
    else if (c == '\t') o += "\\t";
    else if (c < 0x20 || c == 0x7f) {
      char b[8];
      std::snprintf(b, sizeof(b), "\\x%02x", c);
      o += b;
    } else o += static_cast<char>(c);
  }
  return o;
}

void say(const std::string& msg) { std::cerr << "featureextract: " << one_line(msg) << "\n"; }

std::string param_help() {
  std::ostringstream s;
  s << "\nParameters (set them with --config FILE.json or --set NAME=VALUE; L = reference bounding-box diagonal):\n";
  for (const auto& p : fe::param_table()) {
    s << "  " << p.name << " (" << p.type << (p.unit.empty() ? "" : ", " + p.unit) << ", default " << p.default_value << ")\n"
      << "      " << p.help << "\n";
  }
  s << "\nExit codes: 0 done (also when nothing is found), 2 usage error, 3 unreadable or invalid input,\n"
       "4 output not writable, 5 stopped by --time-limit, 1 internal error.\n";
  return s.str();
}

struct Progress {
  bool quiet = false;
  std::string stage;
  double last = -1;
  bool operator()(const std::string& s, double f) {
    if (quiet) return true;
    if (s != stage || f >= last + 0.1 || (f >= 1.0 && last < 1.0)) {
      std::cerr << "featureextract: " << one_line(s) << " " << static_cast<int>(f * 100 + 0.5) << "%\n";
      stage = s;
      last = f;
    }
    return true;
  }
};

// Writes text to path through a temporary file, so a failed run never leaves half a file.
bool write_atomically(const std::string& path, const std::string& text) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
    out << text << "\n";
    out.close();
    if (!out) {
      say(path + ": cannot write output");
      std::remove(tmp.c_str());
      return false;
    }
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    say(path + ": cannot write output");
    std::remove(tmp.c_str());
    return false;
  }
  return true;
}

nlohmann::ordered_json num(double x) { return std::isfinite(x) ? nlohmann::ordered_json(x) : nlohmann::ordered_json(nullptr); }

nlohmann::ordered_json quality(const fe::QualitySummary& q) {
  return {{"elements", q.elements}, {"inverted", q.inverted}, {"min_scaled_jacobian", num(q.min_scaled_jacobian)},
          {"median_scaled_jacobian", num(q.median_scaled_jacobian)}, {"max_aspect_ratio", num(q.max_aspect_ratio)},
          {"median_aspect_ratio", num(q.median_aspect_ratio)}, {"min_angle_deg", num(q.min_angle_deg)}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"FeatureExtract: find every region of a target CAD part or mesh that is similar to a reference feature\n"
               "(Takashima & Kanai's shape-index + multi-radius SHOT method, RANSAC projective transform)."};
  app.require_subcommand(1);
  app.footer(param_help());
  auto* ex = app.add_subcommand("extract", "find the instances of REF in TGT and write them as JSON");
  auto* me = app.add_subcommand("mesh", "find the instances of a reference feature folder's geometry in TGT and place its FE "
                                        "mesh on each (OUT_DIR/instance_NN.inp/.msh/.feature.json, OUT_DIR/result.json)");
  std::string ref_path, tgt_path, out_path, config_path, feature_dir;
  std::string seed_text;
  int threads = -1;
  double time_limit = 0;
  bool quiet = false;
  double max_projection = fe::TransferOptions{}.max_projection;
  std::vector<std::string> sets;
  ex->add_option("--reference,-r", ref_path, "reference feature: STEP, IGES, BREP, STL, OBJ or PLY")->required();
  ex->add_option("--output,-o", out_path, "result JSON file (written atomically)")->required();
  me->add_option("--feature,-f", feature_dir, "reference feature folder: feature.json, geometry, FE mesh (.inp or .msh)")->required();
  me->add_option("--output,-o", out_path, "output folder (created)")->required();
  // CLI11's PositiveNumber lets NaN through
  const CLI::Validator finite_positive([](std::string& v) {
    const double x = std::strtod(v.c_str(), nullptr);
    return std::isfinite(x) && x > 0 ? std::string() : "must be a finite number > 0, got " + v;
  }, "POSITIVE");
  const CLI::Validator finite_non_negative([](std::string& v) {
    const double x = std::strtod(v.c_str(), nullptr);
    return std::isfinite(x) && x >= 0 ? std::string() : "must be a finite number >= 0, got " + v;
  }, "SECONDS");
  me->add_option("--max-projection", max_projection, "largest move of a mapped node onto the target, fraction of the "
                                                     "instance's diagonal (default 0.03)")->check(finite_positive);
  for (CLI::App* sub : {ex, me}) {
    sub->add_option("--target,-t", tgt_path, "target part: STEP, IGES, BREP, STL, OBJ or PLY")->required();
    sub->add_option("--config,-c", config_path, "JSON object of parameters (see below)");
    sub->add_option("--seed", seed_text, "seed of sampling and RANSAC, a whole number >= 0 (default 1)");
    sub->add_option("--threads", threads, "worker threads (default 0 = all cores)")->check(CLI::Range(0, 1024));
    sub->add_option("--time-limit", time_limit, "stop with exit code 5 after this many seconds, reading included (default 0 = "
                                                "no limit; reading a CAD file is always bounded by 20 s + 10 s per MB)")->check(finite_non_negative);
    sub->add_option("--set", sets, "override one parameter, NAME=VALUE (repeatable)");
    sub->add_flag("--quiet,-q", quiet, "no progress on stderr");
    sub->footer(param_help());
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& e) {
    std::cout << app.help() << std::flush;
    return 0;
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);
    say(std::string(e.what()) + " (see featureextract extract --help)");
    return 2;
  }

  fe::Params params;
  if (!config_path.empty()) {  // a config file is input: unreadable or not JSON is exit 3
    std::ifstream in(config_path);
    std::error_code ec;
    if (std::filesystem::is_directory(config_path, ec) || !in) {
      say(config_path + ": cannot open config file");
      return 3;
    }
    std::stringstream ss;
    ss << in.rdbuf();
    const nlohmann::json j = nlohmann::json::parse(ss.str(), nullptr, false);
    if (j.is_discarded() || !j.is_object()) {
      say(config_path + ": not a JSON object of parameters");
      return 3;
    }
    try {
      params = fe::params_from_json(ss.str());
    } catch (const std::invalid_argument& e) {  // a value out of range or an unknown name: usage
      say(config_path + ": " + e.what());
      return 2;
    }
  }
  try {
    for (const std::string& kv : sets) {
      const auto eq = kv.find('=');
      if (eq == std::string::npos) throw std::invalid_argument("expects NAME=VALUE, got '" + kv + "'");
      params = fe::params_from_json("{\"" + kv.substr(0, eq) + "\": " + kv.substr(eq + 1) + "}", params);
    }
  } catch (const std::invalid_argument& e) {
    say(std::string("--set: ") + e.what());
    return 2;
  }
  if (!seed_text.empty()) {
    errno = 0;
    char* end = nullptr;
    const unsigned long long v = std::strtoull(seed_text.c_str(), &end, 10);
    if (seed_text.find_first_not_of("0123456789") != std::string::npos || errno == ERANGE || *end != 0) {
      say("--seed: must be a whole number from 0 to 18446744073709551615, got " + seed_text);
      return 2;
    }
    params.seed = v;
  }
  if (threads >= 0) params.threads = threads;
  try {
    params.validate();
  } catch (const std::invalid_argument& e) {
    say(e.what());
    return 2;
  }
  const auto started = std::chrono::steady_clock::now();

  const bool mesh_mode = me->parsed();
  Progress progress;
  progress.quiet = quiet;
  fe::Result result;
  fe::FeatureModel feature;
  fe::TriangleMesh tgt;
  try {
    if (mesh_mode) {
      feature = fe::read_feature(feature_dir);
      ref_path = feature.geometry_path;
    }
    fe::TessellationOptions to;
    auto left = [&] { return time_limit - std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(); };
    if (time_limit > 0) to.time_limit = std::max(0.01, left());
    const fe::TriangleMesh ref = fe::read_shape(ref_path, to);
    if (time_limit > 0) to.time_limit = std::max(0.01, left());
    tgt = fe::read_shape(tgt_path, fe::tessellation_for_feature(ref.diagonal(), to));
    if (time_limit > 0) {
      if (left() <= 0) throw fe::TimeLimitExceeded("out of time after reading");
      params.time_limit = left();
    }
    for (const fe::TriangleMesh* m : {&ref, static_cast<const fe::TriangleMesh*>(&tgt)})
      if (m->dropped_degenerate > 0 && !m->from_brep() && !quiet)  // BRepMesh's own slivers are routine
        say(m->source + ": warning: " + std::to_string(m->dropped_degenerate) + " zero-area triangles ignored");
    result = fe::extract(ref, tgt, params, std::ref(progress));
  } catch (const fe::InputError& e) {
    say(e.what());
    return 3;
  } catch (const fe::TimeLimitExceeded& e) {
    std::ostringstream m;
    m << tgt_path << ": stopped after the time limit of " << time_limit << " s (--time-limit)";
    say(m.str());
    return 5;
  } catch (const std::exception& e) {
    say(std::string("internal error: ") + e.what());
    return 1;
  }
  if (!quiet) {
    for (const auto& w : result.warnings) say("warning: " + w);
    say(std::to_string(result.matches.size()) + " instance(s) found");
  }
  std::string text;
  try {
    text = fe::result_to_json(result);
  } catch (const std::exception& e) {
    say(out_path + ": cannot encode the result: " + e.what());
    return 1;
  }
  if (!mesh_mode) return write_atomically(out_path, text) ? 0 : 4;

  // mesh: the feature's FE mesh on every instance
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(out_path, ec);
  if (ec || !fs::is_directory(out_path)) {
    say(out_path + ": cannot create the output folder" + (ec ? ": " + ec.message() : ""));
    return 4;
  }
  nlohmann::ordered_json j = nlohmann::ordered_json::parse(text);
  j["feature"] = {{"folder", feature_dir}, {"name", feature.name}, {"mesh", feature.mesh_path},
                  {"nodes", feature.mesh.nodes.rows()}, {"elements", feature.mesh.num_elements()}};
  fe::TransferOptions topt;
  topt.max_projection = max_projection;
  for (std::size_t i = 0; i < result.matches.size(); ++i) {
    char base[32];
    std::snprintf(base, sizeof(base), "instance_%02zu", i + 1);
    const std::string stem = (fs::path(out_path) / base).string();
    progress("mesh transfer", static_cast<double>(i) / static_cast<double>(result.matches.size()));
    nlohmann::ordered_json tj;
    try {
      const fe::TransferredMesh t = fe::transfer_mesh(feature.mesh, result.matches[i].transform, tgt, topt, feature.spec_json);
      fe::write_inp(t.mesh, stem + ".inp");
      fe::write_msh(t.mesh, stem + ".msh");
      if (!write_atomically(stem + ".feature.json", t.spec_json)) return 4;
      tj = {{"inp", std::string(base) + ".inp"}, {"msh", std::string(base) + ".msh"}, {"specification", std::string(base) + ".feature.json"},
            {"nodes", t.mesh.nodes.rows()}, {"projected_nodes", t.projected}, {"unprojected_nodes", t.unprojected},
            {"max_projection_distance", num(t.max_projection_distance)}, {"max_surface_distance", num(t.max_surface_distance)},
            {"quality_before", quality(t.before_summary)}, {"quality_after", quality(t.after_summary)},
            {"invalid_elements", t.invalid_elements}, {"reversed", t.reversed}};
    } catch (const std::runtime_error& e) {  // files that cannot be written
      say(stem + ": " + e.what());
      return 4;
    } catch (const std::exception& e) {  // an instance whose transform cannot carry the mesh
      tj = {{"error", e.what()}};
    }
    j["matches"][i]["transfer"] = tj;
  }
  progress("mesh transfer", 1.0);
  const std::string result_path = (fs::path(out_path) / "result.json").string();
  if (!write_atomically(result_path, j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace))) return 4;
  if (!quiet) say(std::to_string(result.matches.size()) + " mesh(es) written to " + out_path);
  return 0;
}
