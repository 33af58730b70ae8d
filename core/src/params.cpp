// The documented parameter table: one row per Params field, used for --help, JSON and bindings.
#include "featureextract/params.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <variant>

namespace fe {

namespace {

static_assert(std::is_same_v<std::size_t, std::uint64_t>, "size_t parameters are stored as uint64");
using Ptr = std::variant<double Params::*, int Params::*, bool Params::*, std::uint64_t Params::*>;
// The paper's steps (and the run's own settings), in the order the table lists them.
constexpr const char* kSampling = "1. Sampling";
constexpr const char* kDescriptors = "2. Shape index and SHOT";
constexpr const char* kKeyPoints = "3. Key points";
constexpr const char* kPairs = "4. Pairs and clusters";
constexpr const char* kRansac = "5. RANSAC and refinement";
constexpr const char* kAcceptance = "6. Acceptance";
constexpr const char* kReference = "Reference";
constexpr const char* kResult = "Result";
constexpr const char* kRun = "Run";

struct Entry {
  const char* group;
  const char* name;
  Ptr ptr;
  const char* unit;
  const char* help;
  double lo, hi;  // valid range (inclusive)
};

const std::vector<Entry>& entries() {
  static const std::vector<Entry> e = {
      {kSampling, "dense_spacing", &Params::dense_spacing, "x L", "spacing of dense samples (descriptor support, validation)", 1e-4, 0.2},
      {kSampling, "sparse_spacing", &Params::sparse_spacing, "x L", "spacing of sparse samples (candidate key points)", 1e-4, 0.5},
      {kSampling, "max_dense_points", &Params::max_dense_points, "count", "cap on the target's dense samples; beyond it both shapes are described coarser (spacings and normal and curvature radii alike), with a warning", 1000, 5e7},
      {kSampling, "size_ladder", &Params::size_ladder, "steps per 2x", "if > 0, the feature size L (every x L above and below) is rounded to the nearest of this many sizes per doubling, so that features of nearby sizes share the target's descriptions (at most 12 % off L with 3; `search --library` uses 3); 0 = L exactly", 0, 64},
      {kSampling, "normal_radius", &Params::normal_radius, "x L", "support radius of PCA normals", 1e-4, 0.5},
      {kDescriptors, "curvature_radius", &Params::curvature_radius, "x L", "support radius of the quadric fit for principal curvatures", 1e-4, 0.5},
      {kDescriptors, "planar_curvedness", &Params::planar_curvedness, "1/L", "curvedness x L below which a point is planar (shape index -1)", 0, 1e6},
      {kDescriptors, "shot_radius", &Params::shot_radius, "x L", "smallest SHOT support radius", 1e-3, 2},
      {kDescriptors, "shot_radii", &Params::shot_radii, "count", "SHOT radii per descriptor (multi-radius SHOT)", 1, 8},
      {kDescriptors, "shot_radius_ratio", &Params::shot_radius_ratio, "", "ratio of consecutive SHOT radii; also the step of the scale search", 1.05, 3},
      {kDescriptors, "border_skirt", &Params::border_skirt, "", "a reference with an open border (faces picked, cut out with a box, a region of an STL) is continued past it, in the plane of its border triangles and as wide as the largest SHOT radius, in the support of its normals, shape index and SHOT (never as key points, never judged): on the part the surface goes on there. Off by default: it finds a 1 mm sheet's slots picked as faces (3 of 4, 0 without) but loses half-round beads whose border is a sharp turn (2 of 5, 5 without), docs/benchmarks.md", 0, 1},
      {kDescriptors, "scale_min", &Params::scale_min, "", "smallest instance/reference scale searched (SHOT radius shifts; below 0.8 in scale bands: one more pass per band, the reference shrunk and the part described finer, so slower)", 0.1, 1},
      {kDescriptors, "scale_max", &Params::scale_max, "", "largest instance/reference scale searched (SHOT radius shifts; above 2.6 in scale bands, one more pass per band; a match within 5 % of it is fitted again in the band above, as it may be a larger instance squeezed into the range; what that band finds beyond the range is counted in a warning, not reported)", 1, 10},
      {kKeyPoints, "si_band", &Params::si_band, "", "half-width of the rut (0.25) and ridge (0.75) shape-index bands that are not key points", 0, 0.25},
      {kKeyPoints, "ridge_rut_spacing", &Params::ridge_rut_spacing, "x L", "if > 0, ridge and rut points (cylinders: holes, lugs, bosses) are key points too, thinned to one per cube of this size; 0 = the paper's rule", 0, 1},
      {kKeyPoints, "crease_key_points", &Params::crease_key_points, "", "sharp edges and corners where planes meet (machined features), which the curvature fit sees as planes, get the shape index of the rounded crease: edges 0.75 / 0.25 (ridge / rut), corners 1 / 0 / 0.5 (cap / cup / saddle)", 0, 1},
      {kKeyPoints, "ridge_rut_fallback", &Params::ridge_rut_fallback, "x L", "if no instance is found with the key points above (and ridge_rut_spacing is 0), search again with ridge and rut key points thinned to this spacing (features made of cylinders and flats, e.g. lugs); 0 = never", 0, 1},
      {kPairs, "shot_neighbours", &Params::shot_neighbours, "count", "N: nearest reference key points in SHOT space per target key point", 1, 100},
      {kPairs, "si_neighbours", &Params::si_neighbours, "count", "M: nearest reference key points in shape index per target key point", 1, 1000},
      {kPairs, "pair_distance", &Params::pair_distance, "x L", "delta: a SHOT pair is kept if an SI pair lies this close at both ends", 0, 10},
      {kPairs, "cluster_tolerance", &Params::cluster_tolerance, "x L", "Euclidean clustering tolerance of paired target key points", 1e-3, 100},
      {kPairs, "min_cluster_pairs", &Params::min_cluster_pairs, "count", "clusters with fewer key point pairs are dropped", 5, 1e6},
      {kPairs, "vote_reach", &Params::vote_reach, "x L x scale", "each pair's local frames and scale predict where the reference's center lands; votes this close to a peak form one instance's group for RANSAC (separates instances that touch); 0 = the paper's clusters only", 0, 10},
      {kRansac, "ransac_max_iterations", &Params::ransac_max_iterations, "count", "upper bound of RANSAC iterations per instance", 1, 1e7},
      {kRansac, "ransac_patience", &Params::ransac_patience, "count", "RANSAC stops after this many iterations without improvement", 1, 1e7},
      {kRansac, "pose_hypotheses", &Params::pose_hypotheses, "", "besides RANSAC's 5-pair samples, try one placement per pair (rotation from the SHOT local frames, scale from the radius shift): finds instances among many wrong pairs", 0, 1},
      {kRansac, "ransac_unguided_retry", &Params::ransac_unguided_retry, "", "a rejected hypothesis is sought once more among the pairs around it, RANSAC's samples not guided by the pairs' local frames (which turn on an instance stretched unequally along its axes)", 0, 1},
      {kRansac, "topology_hypotheses", &Params::topology_hypotheses, "", "besides the SHOT pairs, match how the reference's faces meet (faces bounded by sharp edges, convex or concave contacts, whole faces whole) on the target's faces, and fit an affine map to the corners where the same faces meet: finds machined features (pockets, slots, steps, passages) of other proportions", 0, 1},
      {kRansac, "refine_iterations", &Params::refine_iterations, "count", "surface refinement (ICP-like) iterations after RANSAC; 0 = the paper's RANSAC result as is", 0, 1000},
      {kRansac, "max_failures", &Params::max_failures, "count", "a cluster is given up after this many rejected transforms in a row", 1, 1e4},
      {kRansac, "max_far_failures", &Params::max_far_failures, "count", "before a cluster's first instance, it is also given up after this many rejected transforms in a row whose error is at its cap (twice accept_error: a tenth or more of the mapped reference lies that far off the target or faces away from it; an absent feature's search ends sooner); 0 = only max_failures", 0, 1e4},
      {kAcceptance, "error_quantile", &Params::error_quantile, "", "error of a transform: 1 = maximum over reference key points (paper), <1 = that quantile", 0.5, 1},
      {kAcceptance, "accept_error", &Params::accept_error, "x L x scale", "a transform is accepted if its error is at most this", 1e-4, 10},
      {kAcceptance, "min_score", &Params::min_score, "", "a transform is accepted if this fraction of the mapped reference lies on the target", 0, 1},
      {kAcceptance, "min_key_agreement", &Params::min_key_agreement, "", "a transform is accepted if this fraction of the reference key points lands near target key points of similar shape index", 0, 1},
      {kAcceptance, "max_obstructed", &Params::max_obstructed, "", "a transform is accepted if at most this fraction of rays along the reference's outward normals, through the space it leaves free (up to where they meet the reference again or leave its box), meets target surface: half of a slot is shaped like a step face for face, but the slot's other wall stands where the step is open; 1 = no check", 0, 1},
      {kAcceptance, "clearance_margin", &Params::clearance_margin, "x L", "how far past the reference's box its free-space rays run (max_obstructed)", 0, 1},
      {kAcceptance, "max_overhang", &Params::max_overhang, "", "a face of the reference that reaches its border (where faces were picked or the box cut) may run on past the end of its face on an instance, into free space: a bolt hole picked in a thick wall found through a thinner one. Such samples are left out of the fit error and the score, up to this share of the reference; 0 = none may", 0, 1},
      {kAcceptance, "max_partial_faces", &Params::max_partial_faces, "", "a transform is accepted if at most this share of the reference's whole B-rep faces (by area) lands on target faces it covers less than 60 % of: a step laid on part of a slot's floor; 1 = no check", 0, 1},
      {kAcceptance, "key_si_tolerance", &Params::key_si_tolerance, "", "shape index difference allowed for key point agreement", 0, 1},
      {kAcceptance, "volume_ratio_min", &Params::volume_ratio_min, "", "lower bound of the volume expansion ratio |det J|", 0, 1e6},
      {kAcceptance, "volume_ratio_max", &Params::volume_ratio_max, "", "upper bound of the volume expansion ratio |det J|", 0, 1e6},
      {kAcceptance, "axis_scale_min", &Params::axis_scale_min, "", "lower bound of every principal stretch (singular value of J)", 0, 1e3},
      {kAcceptance, "axis_scale_max", &Params::axis_scale_max, "", "upper bound of every principal stretch (singular value of J)", 0, 1e3},
      {kAcceptance, "max_anisotropy", &Params::max_anisotropy, "", "largest / smallest principal stretch (oblique distortion bound)", 1, 1e3},
      {kAcceptance, "max_perspective", &Params::max_perspective, "", "largest |w - 1| (relative) of H over the reference box", 0, 10},
      {kAcceptance, "topology_axis_scale_min", &Params::topology_axis_scale_min, "", "axis_scale_min for a transform from a topology match (topology_hypotheses): every face of the feature matched a face of the instance, so an instance of other proportions is still the feature (a slot half as deep)", 0, 1e3},
      {kAcceptance, "topology_axis_scale_max", &Params::topology_axis_scale_max, "", "axis_scale_max for a transform from a topology match", 0, 1e3},
      {kAcceptance, "topology_max_anisotropy", &Params::topology_max_anisotropy, "", "max_anisotropy for a transform from a topology match", 1, 1e3},
      {kAcceptance, "allow_reflection", &Params::allow_reflection, "", "accept mirror-image transforms (negative determinant)", 0, 1},
      {kReference, "mirror", &Params::mirror, "", "also search the mirror image of the reference (skipped when the reference is its own mirror image); such matches have mirrored = true and a negative determinant", 0, 1},
      {kReference, "detect_cut_faces", &Params::detect_cut_faces, "", "a closed reference (a solid cut out of a part with a box) is searched without its cut faces: planar faces on its bounding box that reach another side of the box", 0, 1},
      {kReference, "cut_faces_on_target", &Params::cut_faces_on_target, "", "where a box-cut reference sits on the target unmoved (cut out of that very part), its box faces that lie on the target's surface are the part's own faces (the box reached past the part there) and are kept, not cut", 0, 1},
      {kResult, "face_coverage", &Params::face_coverage, "", "a target face is listed if this fraction of its area is covered by the mapped reference (on a B-rep part, a fit that lists no face is dropped)", 0, 1},
      {kResult, "max_overlap", &Params::max_overlap, "", "instances sharing more than this fraction of their region are reported once", 0, 1},
      {kRun, "seed", &Params::seed, "", "seed of sampling and RANSAC; same input and seed give the same output", 0, 1.8e19},
      {kRun, "threads", &Params::threads, "count", "worker threads for SHOT descriptors; 0 = all cores", 0, 1024},
      {kRun, "time_limit", &Params::time_limit, "s", "an extraction that takes longer stops with an error (CLI exit 5); 0 = no limit", 0, 1e7},
  };
  return e;
}

std::string value_string(const Params& p, const Ptr& ptr) {
  std::ostringstream s;
  std::visit([&](auto m) {
    using T = std::decay_t<decltype(p.*m)>;
    if constexpr (std::is_same_v<T, bool>) s << (p.*m ? "true" : "false");
    else s << p.*m;
  }, ptr);
  return s.str();
}

double as_double(const Params& p, const Ptr& ptr) {
  return std::visit([&](auto m) { return static_cast<double>(p.*m); }, ptr);
}

}  // namespace

const std::vector<ParamInfo>& param_table() {
  static const std::vector<ParamInfo> table = [] {
    std::vector<ParamInfo> t;
    const Params d;
    for (const Entry& e : entries()) {
      std::string type = std::visit([](auto m) -> std::string {
        using T = std::decay_t<decltype(Params{}.*m)>;
        if constexpr (std::is_same_v<T, bool>) return "bool";
        else if constexpr (std::is_same_v<T, double>) return "float";
        else return "int";
      }, e.ptr);
      t.push_back({e.name, type, e.unit, e.help, value_string(d, e.ptr), e.group});
    }
    return t;
  }();
  return table;
}

void Params::validate() const {
  for (const Entry& e : entries()) {
    const double v = as_double(*this, e.ptr);
    if (!std::isfinite(v) || v < e.lo || v > e.hi) {
      std::ostringstream s;
      s << "parameter " << e.name << " = " << value_string(*this, e.ptr) << " is outside [" << e.lo << ", " << e.hi << "]";
      throw std::invalid_argument(s.str());
    }
  }
  auto order = [](const char* a, double x, const char* b, double y) {
    if (x > y) throw std::invalid_argument(std::string("parameter ") + a + " must not exceed " + b);
  };
  order("scale_min", scale_min, "scale_max", scale_max);
  order("volume_ratio_min", volume_ratio_min, "volume_ratio_max", volume_ratio_max);
  order("axis_scale_min", axis_scale_min, "axis_scale_max", axis_scale_max);
  order("dense_spacing", dense_spacing, "sparse_spacing", sparse_spacing);
}

std::string params_to_json(const Params& p) {
  nlohmann::ordered_json j;
  for (const Entry& e : entries())
    std::visit([&](auto m) { j[e.name] = p.*m; }, e.ptr);
  return j.dump();
}

Params params_from_json(const std::string& text, const Params& base) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& ex) {
    throw std::invalid_argument(std::string("not valid JSON: ") + ex.what());
  }
  if (!j.is_object()) throw std::invalid_argument("parameters must be a JSON object");
  Params p = base;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const Entry* found = nullptr;
    for (const Entry& e : entries())
      if (it.key() == e.name) found = &e;
    if (!found) throw std::invalid_argument("unknown parameter '" + it.key() + "'");
    std::visit([&](auto m) {
      using T = std::decay_t<decltype(p.*m)>;
      const auto& v = it.value();
      if constexpr (std::is_same_v<T, bool>) {
        if (!v.is_boolean()) throw std::invalid_argument("parameter " + it.key() + " must be true or false");
        p.*m = v.get<bool>();
      } else if constexpr (std::is_same_v<T, double>) {
        if (!v.is_number()) throw std::invalid_argument("parameter " + it.key() + " must be a number");
        p.*m = v.get<double>();
      } else {
        if (!v.is_number_integer() && !(v.is_number() && std::floor(v.get<double>()) == v.get<double>()))
          throw std::invalid_argument("parameter " + it.key() + " must be a whole number");
        if (v.get<double>() < 0) throw std::invalid_argument("parameter " + it.key() + " must not be negative");
        // range-check before the cast: 1e30 or 2^32+1 would wrap around silently
        constexpr double limit = sizeof(T) >= 8 ? 0x1p63 : static_cast<double>(std::numeric_limits<T>::max()) + 1.0;
        if (v.get<double>() >= limit)
          throw std::invalid_argument("parameter " + it.key() + " is too large (at most " +
                                      std::to_string(static_cast<std::uint64_t>(limit - 1)) + ")");
        p.*m = v.is_number_unsigned() ? static_cast<T>(v.get<std::uint64_t>()) : static_cast<T>(v.get<double>());
      }
    }, found->ptr);
  }
  p.validate();
  return p;
}

}  // namespace fe
