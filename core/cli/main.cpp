// featureextract: command-line front end of the extraction core.
//   featureextract extract --reference REF --target TGT --output OUT.json [--config PARAMS.json]
//                          [--seed N] [--threads N] [--set NAME=VALUE]... [--quiet]
//   featureextract mesh --feature FEATURE_DIR --target TGT --output OUT_DIR [same options]
//       extraction with the feature folder's geometry, then its FE mesh placed on every instance:
//       OUT_DIR/instance_NN.inp, .msh, .feature.json and OUT_DIR/result.json (with a "transfer"
//       entry per match: node projection and element quality before and after)
//   featureextract mesh-part --feature DIR [--feature DIR ...] --target PART --output OUT_DIR [--size S]
//                            [--thickness T] [--force F] [same options]
//       one FE mesh of the whole part (issue 12): every instance of every feature carries its mesh, the
//       rest is meshed by gmsh (core/mesher/fe_gmsh_rest.py, a separate program) on the patches'
//       border nodes: OUT_DIR/part.inp, part.msh, analysis.inp (CalculiX static), mesh_part.json
// Exit codes: 0 done (also when nothing is found), 2 usage error, 3 unreadable or invalid input,
// 4 the output could not be written, 5 stopped by --time-limit, 1 internal error.
#include "featureextract/extract.h"
#include "featureextract/io.h"
#include "featureextract/part_mesh.h"
#include "featureextract/transfer.h"

#include <nlohmann/json.hpp>

#include <CLI/CLI.hpp>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

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
  std::string group;
  for (const auto& p : fe::param_table()) {
    if (p.group != group) s << " " << (group = p.group) << "\n";
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

// Issue 12's quality goal on a placed patch: a scaled Jacobian of at least 0.3 on every element whose
// counterpart in the feature's own mesh has at least 0.5 (an element poor in the reference stays out).
// `total` adds up over the patches.
struct QualityGoal {
  std::size_t judged = 0, below = 0;
  double min_sj = INFINITY;
};
nlohmann::ordered_json quality_goal(const std::vector<fe::ElementQuality>& placed, const std::vector<double>& reference, QualityGoal* total) {
  QualityGoal g;
  if (reference.size() == placed.size())
    for (std::size_t e = 0; e < placed.size(); ++e) {
      if (!(reference[e] >= 0.5)) continue;
      ++g.judged;
      g.min_sj = std::min(g.min_sj, placed[e].scaled_jacobian);
      g.below += placed[e].scaled_jacobian < 0.3;
    }
  if (total) {
    total->judged += g.judged;
    total->below += g.below;
    total->min_sj = std::min(total->min_sj, g.min_sj);
  }
  if (reference.size() != placed.size()) return {{"ok", nullptr}, {"why", "the feature's mesh and the placed one differ in elements"}};
  return {{"elements_good_in_reference", g.judged}, {"min_scaled_jacobian", num(g.min_sj)}, {"below_0_3", g.below}, {"ok", g.below == 0}};
}

// A helper program of the CLI: the file $env names, else `name` next to this executable, else in
// ../share/featureextract beside it (an installed tree); "" when there is none.
std::string helper_program(const char* env, const char* name) {
  std::error_code ec;
  if (const char* e = std::getenv(env); e && *e) return std::filesystem::is_regular_file(e, ec) ? e : "";
  const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
  for (const auto& p : {exe.parent_path() / name, exe.parent_path() / ".." / "share" / "featureextract" / name})
    if (std::filesystem::exists(p, ec)) return p.string();
  return "";
}

// The mesher program (core/mesher/fe_gmsh_rest.py).
std::string mesher_path() { return helper_program("FE_GMSH_REST", "fe_gmsh_rest.py"); }

// Runs argv (no shell), stderr to err_path; returns the exit status, -1 if it could not start or was
// killed by a signal.
int run_program(const std::vector<std::string>& args, const std::string& err_path) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = 0;
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  if (rc != 0) return -1;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0)
    if (errno != EINTR) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string last_line_of(const std::string& path) {
  std::ifstream in(path);
  std::string line, last;
  while (std::getline(in, line))
    if (!line.empty()) last = line;  // the last non-empty line: a traceback ends with the error
  return last;
}


struct MeshPartArgs {
  std::vector<std::string> features;
  std::string target, output;
  double size, thickness, force, max_projection, time_limit;
  bool quiet, plain, solid, linear;
};

// featureextract mesh-part: extraction per feature, the mesh transfer per instance, overlaps resolved,
// the rest meshed by the mesher program, the whole assembled, checked and written with an analysis deck.
int mesh_part(const MeshPartArgs& a, fe::Params params, std::chrono::steady_clock::time_point started) {
  namespace fs = std::filesystem;
  Progress progress;
  progress.quiet = a.quiet;
  const std::string mesher = mesher_path();
  if (mesher.empty()) {
    say("mesh-part: the mesher program fe_gmsh_rest.py is missing (FE_GMSH_REST names no file, or it is not next to "
        "featureextract): reinstall");
    return 1;
  }
  std::error_code ec;
  fs::create_directories(a.output, ec);
  if (ec || !fs::is_directory(a.output)) {
    say(a.output + ": cannot create the output folder" + (ec ? ": " + ec.message() : ""));
    return 4;
  }
  auto left = [&] { return a.time_limit - std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count(); };
  std::vector<fe::PartPatch> patches;
  nlohmann::ordered_json report;
  report["target"] = a.target;
  report["plain"] = a.plain;
  report["features"] = nlohmann::ordered_json::array();
  int part_faces = 0;
  double feature_size = 0, part_diagonal = 0;
  std::vector<Eigen::Vector3d> face_centroids;
  fe::TriangleMesh part_surface;  // the finest tessellation read (quality repair projects onto it)
  fe::TransferOptions topt;
  topt.max_projection = a.max_projection;
  try {
    for (std::size_t fi = 0; fi < a.features.size(); ++fi) {
      const fe::FeatureModel feature = fe::read_feature(a.features[fi]);
      fe::TessellationOptions to;
      if (a.time_limit > 0) to.time_limit = std::max(0.01, left());
      const fe::TriangleMesh ref = fe::read_shape(feature.geometry_path, to);
      if (a.time_limit > 0) to.time_limit = std::max(0.01, left());
      const fe::TriangleMesh tgt = fe::read_shape(a.target, fe::tessellation_for_feature(ref.diagonal(), to));
      if (!tgt.from_brep()) throw fe::InputError(a.target + ": mesh-part needs a B-rep part (STEP, IGES or BREP), not a triangle mesh");
      part_faces = tgt.num_faces;
      part_diagonal = tgt.diagonal();
      if (part_surface.triangles.rows() == 0 || tgt.triangles.rows() > part_surface.triangles.rows()) part_surface = tgt;
      // each face's centroid (of its triangles): the mesher checks that it numbers the faces alike
      face_centroids.assign(static_cast<std::size_t>(tgt.num_faces), Eigen::Vector3d::Zero());
      std::vector<double> area(static_cast<std::size_t>(tgt.num_faces), 0.0);
      for (Eigen::Index t = 0; t < tgt.triangles.rows(); ++t) {
        const int f = tgt.face_ids(t);
        if (f < 1 || f > tgt.num_faces) continue;
        const Eigen::Vector3d p0 = tgt.vertices.row(tgt.triangles(t, 0)).transpose(), p1 = tgt.vertices.row(tgt.triangles(t, 1)).transpose(),
                              p2 = tgt.vertices.row(tgt.triangles(t, 2)).transpose();
        const double ar = 0.5 * (p1 - p0).cross(p2 - p0).norm();
        face_centroids[static_cast<std::size_t>(f - 1)] += ar * (p0 + p1 + p2) / 3.0;
        area[static_cast<std::size_t>(f - 1)] += ar;
      }
      for (std::size_t f = 0; f < area.size(); ++f)
        face_centroids[f] = area[f] > 0 ? Eigen::Vector3d(face_centroids[f] / area[f]) : Eigen::Vector3d::Constant(NAN);
      if (a.time_limit > 0) {
        if (left() <= 0) throw fe::TimeLimitExceeded("out of time after reading");
        params.time_limit = left();
      }
      if (!a.quiet) say("mesh-part: feature " + std::to_string(fi + 1) + " of " + std::to_string(a.features.size()) + ": " + feature.name);
      const fe::Result result = fe::extract(ref, tgt, params, std::ref(progress));
      const nlohmann::json spec = nlohmann::json::parse(feature.spec_json, nullptr, false);
      std::vector<std::string> rigid;
      if (spec.is_object() && spec.contains("analysis") && spec["analysis"].is_array())
        for (const auto& an : spec["analysis"])
          if (an.is_object() && an.contains("kind") && an["kind"] == "rigid_body" && an.contains("node_set") && an["node_set"].is_string())
            rigid.push_back(an["node_set"].get<std::string>());
      if (spec.is_object() && spec.contains("element") && spec["element"].is_object() && spec["element"].contains("size") &&
          spec["element"]["size"].is_number())
        feature_size = feature_size > 0 ? std::min(feature_size, spec["element"]["size"].get<double>()) : spec["element"]["size"].get<double>();
      std::vector<double> reference_sj;
      for (const fe::ElementQuality& q : fe::element_quality(feature.mesh)) reference_sj.push_back(q.scaled_jacobian);
      nlohmann::ordered_json fj = {{"folder", a.features[fi]}, {"name", feature.name}, {"found", result.matches.size()}};
      std::size_t k = 0, morphed_instances = 0;
      for (const fe::Match& m : result.matches) {
        ++k;
        fe::PartPatch p;
        p.name = fe::set_name(feature.name) + "_" + std::to_string(k);
        try {
          fe::TransferredMesh t = fe::transfer_mesh(feature.mesh, m.transform, tgt, topt, feature.spec_json);
          p.mesh = std::move(t.mesh);
          p.spec_json = t.spec_json;
        } catch (const std::exception& e) {
          fj["skipped"].push_back(p.name + ": " + e.what());
          continue;
        }
        p.faces = m.faces;
        p.score = m.score;
        p.reference_scaled_jacobian = reference_sj;
        p.feature = feature.name;
        // the faces the placed mesh covers, not every face the fit comes near (those the mesher must mesh)
        const fe::ClaimReport claim = fe::claim_covered_faces(p, tgt);
        if (!claim.dropped_faces.empty()) {
          std::ostringstream s;
          s << p.name << ": face(s)";
          for (const int f : claim.dropped_faces) s << " " << f;
          s << " left to the rest (the feature's mesh covers less than half of each";
          if (claim.removed_elements) s << "; " << claim.removed_elements << " of its elements on them removed";
          s << ")";
          fj["faces_left_to_the_rest"].push_back(s.str());
          if (!a.quiet) say("mesh-part: " + s.str());
        }
        if (!claim.dropped_faces.empty() && (p.faces.empty() || p.mesh.num_elements() == 0)) {
          fj["skipped"].push_back(p.name + ": its mesh covers none of the faces it was found on");
          continue;
        }
        // placed again with feet on the claimed faces only (the faces the mesher puts the patch on): a
        // fit a little past them morphs back inside there, where it would fold onto their edge in the
        // mesher. Kept where the morph was (CTC-02: lugs 1, 4 and 5); elsewhere the first placement stays
        if (claim.removed_elements == 0 && tgt.from_brep() && !p.faces.empty()) {
          fe::TransferOptions on_faces = topt;
          on_faces.faces = p.faces;
          std::sort(on_faces.faces.begin(), on_faces.faces.end());
          try {
            fe::TransferredMesh t = fe::transfer_mesh(feature.mesh, m.transform, tgt, on_faces, feature.spec_json);
            if (t.morphed > 0) {
              p.mesh = std::move(t.mesh);
              ++morphed_instances;
            }
          } catch (const std::exception&) {
            // the first placement stays
          }
        }
        for (const auto& r : rigid)
          if (p.mesh.node_sets.count(r)) p.rigid_sets.push_back(p.name + "_" + r);
        patches.push_back(std::move(p));
      }
      fj["morphed_onto_faces"] = morphed_instances;  // instances whose border was past their faces, morphed back
      report["features"].push_back(fj);
    }
  } catch (const fe::InputError& e) {
    say(e.what());
    return 3;
  } catch (const fe::TimeLimitExceeded&) {
    std::ostringstream m;
    m << a.target << ": stopped after the time limit of " << a.time_limit << " s (--time-limit)";
    say(m.str());
    return 5;
  } catch (const std::exception& e) {
    say(std::string("internal error: ") + e.what());
    return 1;
  }
  const std::vector<std::string> dropped = fe::resolve_overlaps(patches);
  for (const auto& d : dropped)
    if (!a.quiet) say("mesh-part: " + d);
  report["overlaps"] = dropped;
  const double size = a.size > 0 ? a.size : (feature_size > 0 ? 2 * feature_size : part_diagonal / 50);
  report["size"] = size;
  // the mesher, a separate program
  const std::string job_path = (fs::path(a.output) / "mesher_job.json").string();
  const std::string answer_path = (fs::path(a.output) / "mesher_answer.json").string();
  const std::string err_path = (fs::path(a.output) / "mesher.log").string();
  if (!write_atomically(job_path, fe::part_mesh_job(fs::absolute(a.target).string(), part_faces, size, patches, a.plain, 1.5, face_centroids))) return 4;
  progress("meshing the rest (gmsh)", 0.0);
  const int rc = run_program({"/usr/bin/python3", mesher, job_path, answer_path}, err_path);
  if (rc != 0) {
    const std::string why = last_line_of(err_path);
    say(a.target + ": the rest of the part could not be meshed: " + (why.empty() ? "the mesher stopped (status " + std::to_string(rc) + ")" : why));
    return rc == 1 || rc == -1 ? 1 : 3;
  }
  progress("meshing the rest (gmsh)", 1.0);
  std::ifstream in(answer_path);
  std::stringstream ss;
  ss << in.rdbuf();
  fe::PartMeshReport rep;
  fe::FeMesh whole;
  try {
    whole = fe::assemble_part_mesh(a.plain ? std::vector<fe::PartPatch>{} : patches, ss.str(), &rep);
  } catch (const std::exception& e) {
    say(std::string("internal error: ") + e.what());
    return 1;
  }
  // quality repair of the patches: their border and joined nodes stay
  if (!a.plain) {
    std::vector<int> locked;
    std::vector<fe::NodeAxis> circles;
    long base = 0;
    for (const auto& p : patches) {
      for (const int b : fe::border_nodes(p.mesh)) locked.push_back(static_cast<int>(base + b));
      const nlohmann::json spec = nlohmann::json::parse(p.spec_json, nullptr, false);
      bool on_circles = false;
      if (spec.is_object() && spec.contains("rules") && spec["rules"].is_array())
        for (const auto& r : spec["rules"]) on_circles = on_circles || (r.is_object() && r.contains("rule") && r["rule"] == "nodes_on_circles");
      if (on_circles && spec.contains("axis") && spec["axis"].is_object()) {
        fe::NodeAxis ax;
        for (int k = 0; k < 3; ++k) {
          ax.point(k) = spec["axis"]["point"][static_cast<std::size_t>(k)].get<double>();
          ax.direction(k) = spec["axis"]["direction"][static_cast<std::size_t>(k)].get<double>();
        }
        for (Eigen::Index i = 0; i < p.mesh.nodes.rows(); ++i) ax.nodes.push_back(static_cast<int>(base + i));
        circles.push_back(std::move(ax));
      }
      base += p.mesh.nodes.rows();
    }
    progress("repairing the patches", 0.0);
    const fe::RepairReport rr = fe::repair_patches(whole, rep.patch_elements, part_surface, locked, 0.3, 20, circles);
    progress("repairing the patches", 1.0);
    report["repair"] = {{"inverted_before", rr.inverted_before}, {"inverted_after", rr.inverted_after},
                        {"poor_before", rr.poor_before}, {"poor_after", rr.poor_after},
                        {"moved_nodes", rr.moved_nodes}, {"passes", rr.passes},
                        {"rule", "poor: scaled Jacobian below 0.3 (the quality goal), the worse of it against the element's own normal and against the mean normal of its neighbours"}};
  }
  const std::vector<fe::ElementQuality> q = fe::element_quality(whole);
  std::vector<fe::ElementQuality> qp(q.begin(), q.begin() + static_cast<std::ptrdiff_t>(rep.patch_elements)),
      qr(q.begin() + static_cast<std::ptrdiff_t>(rep.patch_elements), q.end());
  // --solid: the same surface filled with tetrahedra by the mesher
  fe::FeMesh solid;
  if (a.solid) {
    const std::string fjob = (fs::path(a.output) / "mesher_fill_job.json").string();
    const std::string fans = (fs::path(a.output) / "mesher_fill_answer.json").string();
    if (!write_atomically(fjob, fe::fill_job(whole, size))) return 4;
    progress("filling the part with tetrahedra (gmsh)", 0.0);
    const int frc = run_program({"/usr/bin/python3", mesher, fjob, fans}, err_path);
    if (frc != 0) {
      const std::string why = last_line_of(err_path);
      say(a.target + ": the part could not be filled with tetrahedra: " + (why.empty() ? "the mesher stopped (status " + std::to_string(frc) + ")" : why));
      return frc == 2 ? 3 : 1;
    }
    progress("filling the part with tetrahedra (gmsh)", 1.0);
    std::ifstream fin(fans);
    std::stringstream fss;
    fss << fin.rdbuf();
    try {
      solid = fe::solid_from_fill(whole, fss.str());
    } catch (const std::exception& e) {
      say(std::string("internal error: ") + e.what());
      return 1;
    }
    std::size_t on_part = 0, on_brep = 0;
    std::string projection_note;
    if (!a.linear) {
      progress("10-node tetrahedra", 0.0);
      // the surface middles onto the exact B-rep faces, by the mesher (it holds the B-rep)
      const fe::FaceProjector onto_faces = [&](fe::Points& pts, const std::vector<int>& faces) {
        const std::string pjob = (fs::path(a.output) / "mesher_project_job.json").string();
        const std::string pans = (fs::path(a.output) / "mesher_project_answer.json").string();
        nlohmann::json j = {{"project", true}, {"part", fs::absolute(a.target).string()}, {"points", nlohmann::json::array()}};
        for (Eigen::Index i = 0; i < pts.rows(); ++i)
          j["points"].push_back({pts(i, 0), pts(i, 1), pts(i, 2), faces[static_cast<std::size_t>(i)]});
        if (!write_atomically(pjob, j.dump())) return;
        progress("10-node tetrahedra: middles onto the B-rep (gmsh)", 0.0);
        const std::string plog = (fs::path(a.output) / "mesher_project.log").string();  // mesher.log stays the rest's
        const int prc = run_program({"/usr/bin/python3", mesher, pjob, pans}, plog);
        if (prc != 0) {  // the triangulation's feet stay: a coarser curve, not a failure
          projection_note = "not onto the B-rep (" + last_line_of(plog) + "): on the triangulation";
          return;
        }
        std::ifstream pin(pans);
        const nlohmann::json ans = nlohmann::json::parse(pin, nullptr, false);
        if (!ans.is_object() || !ans.contains("points") || !ans["points"].is_array() ||
            ans["points"].size() != static_cast<std::size_t>(pts.rows())) {
          projection_note = "not onto the B-rep (the mesher's answer does not fit): on the triangulation";
          return;
        }
        for (Eigen::Index i = 0; i < pts.rows(); ++i) {
          const auto& q = ans["points"][static_cast<std::size_t>(i)];
          if (q.is_array() && q.size() == 3 && q[0].is_number() && q[1].is_number() && q[2].is_number())
            pts.row(i) << q[0].get<double>(), q[1].get<double>(), q[2].get<double>();
        }
      };
      solid = fe::quadratic_solid(solid, whole, part_surface, &on_part, part_surface.from_brep() ? onto_faces : fe::FaceProjector{}, &on_brep);
      progress("10-node tetrahedra", 1.0);
    }
    const auto qs = fe::element_quality(solid);
    report["solid"] = {{"inp", "part_solid.inp"}, {"msh", "part_solid.msh"}, {"nodes", solid.nodes.rows()},
                       {"elements", solid.num_elements()}, {"type", a.linear ? "C3D4" : "C3D10"},
                       {"middle_nodes_on_part", on_part}, {"middle_nodes_onto_brep", on_brep}, {"quality", quality(fe::summarize(qs))}};
    if (!projection_note.empty()) report["solid"]["middle_nodes_note"] = projection_note;
  }
  // equations in a profile-reducing order (part_mesh.h); the surface and the solid each their own
  fe::number_nodes_for_solver(whole);
  if (a.solid) fe::number_nodes_for_solver(solid);
  try {
    fe::write_inp(whole, (fs::path(a.output) / "part.inp").string());
    fe::write_msh(whole, (fs::path(a.output) / "part.msh").string());
    if (a.solid) {
      fe::write_inp(solid, (fs::path(a.output) / "part_solid.inp").string());
      fe::write_msh(solid, (fs::path(a.output) / "part_solid.msh").string());
    }
    fe::StaticAnalysis an;
    an.thickness = a.thickness;
    an.force = a.force;
    an.solid = a.solid;
    for (const auto& p : patches) {
      if (!a.plain && !a.solid) an.section_sets.push_back(p.name);
      for (const auto& r : p.rigid_sets) an.rigid_sets.push_back(r);
    }
    if (a.solid) an.section_sets.push_back("PART_SOLID");
    else if (rep.rest_elements > 0) an.section_sets.push_back("PART_REST");
    if (!whole.node_sets.count("FIXED")) throw std::runtime_error("no face of the rest to hold the part by (every face is covered)");
    fe::write_ccx_static(a.solid ? solid : whole, a.solid ? "part_solid.inp" : "part.inp", an,
                         (fs::path(a.output) / "analysis.inp").string());
    report["analysis"] = {{"deck", "analysis.inp"}, {"mesh", a.solid ? "part_solid.inp" : "part.inp"},
                          {"model", a.solid ? (a.linear ? "solid (C3D4)" : "solid (C3D10)") : "shell"}, {"thickness", a.solid ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(a.thickness)},
                          {"force", a.force}, {"rigid_sets", an.rigid_sets}, {"fixed_face", rep.fixed_face}};
  } catch (const std::exception& e) {
    say(a.output + ": " + e.what());
    return 4;
  }
  report["instances"] = nlohmann::ordered_json::array();
  QualityGoal goal;
  long row0 = 0;
  int el0 = 0;  // blocks before this patch's
  for (const auto& p : patches) {
    // the rules, checked on the patch as it ends up in the whole mesh (on the B-rep, repaired)
    fe::FeMesh placed = p.mesh;
    if (!a.plain) {
      placed.nodes = whole.nodes.middleRows(row0, p.mesh.nodes.rows());
      for (std::size_t b = 0; b < placed.blocks.size(); ++b)  // the whole mesh's blocks start with the patches', in order
        placed.blocks[b].conn = whole.blocks[b + static_cast<std::size_t>(el0)].conn.array() - static_cast<int>(row0);
    }
    row0 += p.mesh.nodes.rows();
    el0 += static_cast<int>(p.mesh.blocks.size());
    nlohmann::ordered_json rules = nlohmann::ordered_json::parse(fe::check_rules(placed, p.spec_json));
    if (const std::string zone = a.plain ? "" : fe::check_transition(whole, rep.patch_elements, placed, p.spec_json, size); !zone.empty())
      for (auto& r : rules)
        if (r.contains("rule") && r["rule"] == "transition_zone") r = nlohmann::ordered_json::parse(zone);
    const Eigen::Vector3d lo = p.mesh.nodes.colwise().minCoeff().transpose(), hi = p.mesh.nodes.colwise().maxCoeff().transpose();
    const std::vector<fe::ElementQuality> placed_q = fe::element_quality(placed);
    report["instances"].push_back({{"name", p.name}, {"feature", p.feature}, {"score", p.score}, {"faces", p.faces},
                                   {"nodes", p.mesh.nodes.rows()}, {"elements", p.mesh.num_elements()},
                                   {"bbox_min", {lo.x(), lo.y(), lo.z()}}, {"bbox_max", {hi.x(), hi.y(), hi.z()}},
                                   {"rigid_sets", p.rigid_sets}, {"quality", quality(fe::summarize(placed_q))},
                                   {"quality_goal", quality_goal(placed_q, p.reference_scaled_jacobian, &goal)},
                                   {"rules", rules}});
  }
  report["mesh"] = {{"inp", "part.inp"}, {"msh", "part.msh"}, {"nodes", whole.nodes.rows()}, {"elements", whole.num_elements()},
                    {"patch_nodes", rep.patch_nodes}, {"patch_elements", rep.patch_elements},
                    {"rest_nodes", rep.rest_nodes}, {"rest_elements", rep.rest_elements}, {"joined_nodes", rep.joined_nodes},
                    {"moved_onto_brep", rep.moved_nodes}};
  report["conformity"] = {{"duplicate_nodes", rep.duplicate_nodes}, {"free_edges", rep.free_edges},
                          {"free_edges_at_patches", rep.free_edges_at_patches},
                          {"border_nodes_not_joined", rep.border_nodes_not_joined}};
  report["quality"] = {{"patches", quality(fe::summarize(qp))}, {"rest", quality(fe::summarize(qr))}, {"all", quality(fe::summarize(q))},
                       {"goal", {{"rule", "scaled Jacobian >= 0.3 on every patch element whose reference element has >= 0.5"},
                                 {"elements_judged", goal.judged}, {"min_scaled_jacobian", num(goal.min_sj)}, {"below_0_3", goal.below},
                                 {"ok", goal.below == 0}}}};
  report["mesher"] = nlohmann::ordered_json::parse(rep.mesher_report.empty() ? "{}" : rep.mesher_report, nullptr, false);
  report["seconds"] = std::chrono::duration<double>(std::chrono::steady_clock::now() - started).count();
  if (!write_atomically((fs::path(a.output) / "mesh_part.json").string(),
                        report.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace)))
    return 4;
  if (!a.quiet) {
    std::ostringstream m;
    m << "mesh-part: " << patches.size() << " instance(s), " << whole.nodes.rows() << " nodes, " << whole.num_elements()
      << " elements; " << rep.free_edges << " free edges, " << rep.duplicate_nodes << " duplicate nodes, "
      << rep.border_nodes_not_joined << " border nodes not joined -> " << a.output;
    say(m.str());
  }
  return 0;
}
// The library program (core/library/fe_library.py: library, search, batch, report).
std::string library_program() { return helper_program("FE_LIBRARY_PROGRAM", "fe_library.py"); }
}  // namespace

int main(int argc, char** argv) {
  // OpenMP threads that wait for each other spin by default (GCC's libgomp, up to 300,000 turns at
  // every join); with another program busy on the machine they spin while the thread they wait for is
  // not running. Measured with one busy process beside it: CTC-02's lug 28.0 -> 21.3 s, an MFCAD
  // search 7.3 -> 4.9 s; alone the same within noise. libgomp reads the policy only when it starts,
  // so the program starts again once with OMP_WAIT_POLICY=PASSIVE unless the caller chose a policy
  // (set one when running it under valgrind, which does not follow the new start by default).
  if (!std::getenv("OMP_WAIT_POLICY") && setenv("OMP_WAIT_POLICY", "PASSIVE", 1) == 0) {
    execv("/proc/self/exe", argv);  // on failure the run goes on with the default policy
  }
  // library, search, batch and report are Python (Dask, the databases' drivers): this process becomes it
  if (argc >= 2) {
    const std::string sub = argv[1];
    if (sub == "library" || sub == "search" || sub == "batch" || sub == "report") {
      const std::string prog = library_program();
      if (prog.empty()) {
        std::fprintf(stderr, "featureextract %s: the library program fe_library.py is missing (FE_LIBRARY_PROGRAM names no file, "
                             "or it is not next to the featureextract executable)\n", sub.c_str());
        return 4;
      }
      std::vector<char*> args{const_cast<char*>("/usr/bin/python3"), const_cast<char*>(prog.c_str())};
      for (int i = 1; i < argc; ++i) args.push_back(argv[i]);
      args.push_back(nullptr);
      execv(args[0], args.data());
      std::fprintf(stderr, "featureextract %s: cannot start /usr/bin/python3: %s\n", sub.c_str(), std::strerror(errno));
      return 4;
    }
  }
  CLI::App app{"FeatureExtract: find every region of a target CAD part or mesh that is similar to a reference feature\n"
               "(Takashima & Kanai's shape-index + multi-radius SHOT method, RANSAC projective transform)."};
  app.require_subcommand(1);
  app.set_version_flag("--version", std::string("featureextract ") + FE_VERSION);
  app.footer(param_help());
  auto* ex = app.add_subcommand("extract", "find the instances of REF in TGT and write them as JSON");
  auto* me = app.add_subcommand("mesh", "find the instances of a reference feature folder's geometry in TGT and place its FE "
                                        "mesh on each (OUT_DIR/instance_NN.inp/.msh/.feature.json, OUT_DIR/result.json)");
  // listed for --help; run by fe_library.py (above)
  for (const auto& [name, what] : std::vector<std::pair<std::string, std::string>>{
           {"library", "a folder of reference features: library add LIB --from PART --faces 12,13 --name NAME | list LIB | check LIB"},
           {"search", "every instance of every library feature on one part: search --library LIB --target PART --output OUT.json"},
           {"batch", "search every part of a vault on Dask into SQLite/PostgreSQL: batch --library LIB --parts 'vault/**/*.step' --db results.sqlite"},
           {"report", "an HTML page and CSV of a batch database: report --db results.sqlite --output report.html"}})
    app.add_subcommand(name, what)->allow_extras();
  auto* mp = app.add_subcommand("mesh-part", "one FE mesh of the whole part: every instance of every feature carries the "
                                             "feature's mesh, the rest is meshed by gmsh, conforming (OUT_DIR/part.inp, "
                                             "part.msh, analysis.inp, mesh_part.json)");
  std::string ref_path, tgt_path, out_path, config_path, feature_dir;
  std::vector<std::string> feature_dirs;
  double part_size = 0, thickness = 0.2, force = 100.0;
  bool plain = false, solid = false, linear = false;
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
  }, ">= 0");
  me->add_option("--max-projection", max_projection, "largest move of a mapped node onto the target, fraction of the "
                                                     "instance's diagonal (default 0.03)")->check(finite_positive);
  mp->add_option("--feature,-f", feature_dirs, "reference feature folder (repeatable)")->required();
  mp->add_option("--output,-o", out_path, "output folder (created)")->required();
  mp->add_option("--size", part_size, "element size of the rest of the part (default: the features' element size, "
                                      "else 1/50 of the part's diagonal)")->check(finite_positive);
  mp->add_option("--thickness", thickness, "shell thickness of the analysis deck (default 0.2)")->check(finite_positive);
  CLI::Option* solid_flag = mp->add_flag("--solid", solid, "also fill the surface mesh with 10-node tetrahedra (C3D10, part_solid.inp/.msh; their "
                                 "middle nodes on the part's B-rep faces); the analysis deck then uses the solid");
  mp->add_flag("--linear", linear, "with --solid: 4-node tetrahedra (C3D4) instead of 10-node ones")->needs(solid_flag);
  mp->add_flag("--plain", plain, "mesh the whole part with gmsh, no feature mesh placed (the same analysis on a mesh "
                                 "without feature rules, for comparison); the features still say where the bolts are");
  mp->add_option("--force", force, "force on each rigid bolt connection, along -z, in N (default 100)")->check(finite_non_negative);
  for (CLI::App* sub : {ex, me, mp}) {
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

  if (mp->parsed()) {
    MeshPartArgs a{feature_dirs, tgt_path, out_path, part_size, thickness, force, max_projection, time_limit, quiet, plain, solid, linear};
    return mesh_part(a, params, started);
  }
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
    std::ostringstream m;  // the file being read when the time ran out (the reference's), else the target
    const std::string what = e.what();
    m << (!ref_path.empty() && what.rfind(ref_path + ":", 0) == 0 ? ref_path : tgt_path) << ": stopped after the time limit of "
      << time_limit << " s (--time-limit)";
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
