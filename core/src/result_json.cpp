// The result JSON of the CLI contract. Non-finite numbers never reach the file (they become null).
#include "featureextract/result.h"

#include <nlohmann/json.hpp>

#include <cmath>

namespace fe {

namespace {
nlohmann::ordered_json num(double x) { return std::isfinite(x) ? nlohmann::ordered_json(x) : nlohmann::ordered_json(nullptr); }
nlohmann::ordered_json vec(const Eigen::Vector3d& v) { return {num(v.x()), num(v.y()), num(v.z())}; }
nlohmann::ordered_json stats(const ShapeStats& s) {
  return {{"triangles", s.triangles}, {"faces", s.faces}, {"dense_points", s.dense_points},
          {"sparse_points", s.sparse_points}, {"key_points", s.key_points}, {"descriptors", s.descriptors},
          {"dropped_degenerate_triangles", s.dropped_degenerate}, {"diagonal", num(s.diagonal)}};
}
}  // namespace

std::string result_to_json(const Result& r, int indent) {
  nlohmann::ordered_json j;
  j["matches"] = nlohmann::ordered_json::array();
  for (const Match& m : r.matches) {
    nlohmann::ordered_json t = nlohmann::ordered_json::array();
    for (int i = 0; i < 4; ++i) t.push_back({num(m.transform(i, 0)), num(m.transform(i, 1)), num(m.transform(i, 2)), num(m.transform(i, 3))});
    nlohmann::ordered_json o;
    o["transform"] = t;
    o["score"] = num(m.score);
    o["max_error"] = num(m.max_error);
    o["rms_error"] = num(m.rms_error);
    o["rms_error_unrefined"] = num(m.rms_error_unrefined);
    o["scale"] = num(m.scale);
    o["center"] = vec(m.center);
    o["bbox"] = {vec(m.bbox_min), vec(m.bbox_max)};
    o["faces"] = m.faces;
    nlohmann::ordered_json shares = nlohmann::ordered_json::array();
    for (const auto& [f, share] : m.face_shares) shares.push_back({f, std::round(1000 * share) / 1000});
    o["face_shares"] = shares;
    if (!m.triangles.empty()) o["triangles"] = m.triangles;
    o["pairs"] = m.pairs;
    o["key_agreement"] = num(m.key_agreement);
    o["stretch"] = {num(m.stretch_min), num(m.stretch_max)};
    o["perspective"] = num(m.perspective);
    o["obstructed"] = num(m.obstructed);
    o["overhang"] = num(m.overhang);
    o["mirrored"] = m.mirrored;
    j["matches"].push_back(o);
  }
  j["reference"] = stats(r.reference);
  j["reference"]["closed"] = r.reference_closed;
  j["reference"]["cut_faces"] = r.reference_cut_faces;
  j["reference"]["own_faces"] = r.reference_own_faces;
  j["reference"]["cut_triangles"] = r.reference_cut_triangles;
  j["reference"]["cut_sides"] = r.reference_cut_sides;
  j["reference"]["mirror_symmetric"] = r.reference_mirror_symmetric;
  j["reference"]["mirror_searched"] = r.mirror_searched;
  j["target"] = stats(r.target);
  j["feature_size"] = num(r.feature_size);
  j["symmetry"] = {{"kind", r.symmetry}};
  if (r.symmetry != "none") j["symmetry"]["axis"] = {vec(r.symmetry_point), vec(r.symmetry_axis)};
  j["pairs"] = {{"shot", r.pairs_shot}, {"shot_si_filtered", r.pairs_ss}, {"clusters", r.clusters}, {"topology_matches", r.topology_matches},
                {"ransac_searches", r.ransac_searches}};
  j["parameters"] = nlohmann::ordered_json::parse(params_to_json(r.params));
  nlohmann::ordered_json t = nlohmann::ordered_json::object();
  double total = 0;
  for (const auto& s : r.timings) {
    t[s.first] = num(s.second);
    total += s.second;
  }
  t["total"] = num(total);
  j["timings"] = t;
  j["warnings"] = r.warnings;
  // warnings may quote file names that are not UTF-8: replace such bytes instead of throwing
  return j.dump(indent, ' ', false, nlohmann::ordered_json::error_handler_t::replace);
}

}  // namespace fe
