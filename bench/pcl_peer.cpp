// fe_pcl_peer: a peer for the benchmark suite. PCL's own "3D Object Recognition based on
// Correspondence Grouping" tutorial method (SHOT descriptors + GeometricConsistencyGrouping, or BOARD
// reference frames + Hough3DGrouping with --hough), run on our inputs. Rigid: it finds rototranslated
// copies of the reference only.
//
//   fe_pcl_peer --reference REF --target TGT --output OUT.json [--seed N] [--threads N] [--hough]
//
// Differences from the tutorial, all forced by our inputs being CAD parts in mm rather than point clouds
// in metres: points are sampled on the tessellated surfaces (area-weighted, seeded), every size is
// relative to the reference's bounding-box diagonal L, and normals are by default the normals of the
// sampled triangles (outward, consistently oriented) rather than NormalEstimationOMP's k=10 normals,
// whose sign is arbitrary on a CAD part (--pcl-normals selects the tutorial's estimator, oriented
// towards the viewpoint like the tutorial). Tuned on ribs_bosses only; see `parameters` in the output.
//
// Exit codes: 0 ok (also when nothing is found), 2 usage error, 3 unreadable input.
#include "featureextract/io.h"
#include "featureextract/mesh.h"

#include <pcl/console/print.h>
#include <pcl/correspondence.h>
#include <pcl/features/board.h>
#include <pcl/features/normal_3d_omp.h>
#include <pcl/features/shot_omp.h>
#include <pcl/filters/uniform_sampling.h>
#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/recognition/cg/geometric_consistency.h>
#include <pcl/recognition/cg/hough_3d.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <random>
#include <string>
#include <thread>
#include <vector>

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

struct Options {
  std::string reference, target, output;
  unsigned seed = 1;
  int threads = 0;
  bool hough = false;
  bool pcl_normals = false;
  // Sizes relative to the reference diagonal L (tuned on ribs_bosses only).
  double spacing = 1.0 / 100;     // sampling spacing
  double model_ss = 1.0 / 45;     // UniformSampling radius, reference
  double scene_ss = 1.0 / 30;     // UniformSampling radius, target
  double descr_rad = 1.0 / 6;     // SHOT support radius
  double rf_rad = 1.0 / 8;        // BOARD support radius (--hough); tutorial: 0.75 descr_rad
  // GC consensus size / Hough bin size, and GC / Hough threshold (tutorial: 5 for both, which gives a
  // hundred groups on a plate). Negative: the mode's default, GC 1/30 and 15, Hough 1/20 and 10.
  double cg_size = -1;
  double cg_thresh = -1;
  double corr_max = 0.25;         // squared SHOT distance, as in the tutorial
  double dedup = 1.0 / 4;         // duplicate instances: mapped centers closer than this * L
  int normal_k = 10;              // --pcl-normals: NormalEstimationOMP k
};

const char* kUsage =
    "usage: fe_pcl_peer --reference REF --target TGT --output OUT.json [--seed N] [--threads N] [--hough]\n"
    "       tuning (fractions of the reference diagonal L): --spacing --model-ss --scene-ss --descr-rad\n"
    "       --rf-rad --cg-size; --cg-thresh N; --corr-max D2; --pcl-normals\n";

bool parse_number(const std::string& s, double& out) {
  try {
    std::size_t pos = 0;
    out = std::stod(s, &pos);
    return pos == s.size() && std::isfinite(out);
  } catch (...) {
    return false;
  }
}

// Returns false on a usage error (message already printed).
bool parse_args(int argc, char** argv, Options& o) {
  auto fail = [](const std::string& msg) {
    std::fprintf(stderr, "fe_pcl_peer: %s\n%s", msg.c_str(), kUsage);
    return false;
  };
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--hough") { o.hough = true; continue; }
    if (a == "--pcl-normals") { o.pcl_normals = true; continue; }
    if (a == "-h" || a == "--help") return fail("help requested");
    if (i + 1 >= argc) return fail("missing value after " + a);
    const std::string v = argv[++i];
    double x = 0;
    auto num = [&](double& dst, double lo) {
      if (!parse_number(v, x) || x < lo) return false;
      dst = x;
      return true;
    };
    if (a == "--reference") o.reference = v;
    else if (a == "--target") o.target = v;
    else if (a == "--output") o.output = v;
    else if (a == "--seed") {
      if (!parse_number(v, x) || x < 0 || x > 4294967295.0 || x != std::floor(x)) return fail("bad --seed " + v);
      o.seed = static_cast<unsigned>(x);
    } else if (a == "--threads") {
      if (!parse_number(v, x) || x < 0 || x > 1024 || x != std::floor(x)) return fail("bad --threads " + v);
      o.threads = static_cast<int>(x);
    } else if (a == "--spacing") { if (!num(o.spacing, 1e-4)) return fail("bad " + a); }
    else if (a == "--model-ss") { if (!num(o.model_ss, 1e-4)) return fail("bad " + a); }
    else if (a == "--scene-ss") { if (!num(o.scene_ss, 1e-4)) return fail("bad " + a); }
    else if (a == "--descr-rad") { if (!num(o.descr_rad, 1e-4)) return fail("bad " + a); }
    else if (a == "--rf-rad") { if (!num(o.rf_rad, 1e-4)) return fail("bad " + a); }
    else if (a == "--cg-size") { if (!num(o.cg_size, 1e-4)) return fail("bad " + a); }
    else if (a == "--cg-thresh") { if (!num(o.cg_thresh, 1)) return fail("bad " + a); }
    else if (a == "--corr-max") { if (!num(o.corr_max, 0)) return fail("bad " + a); }
    else return fail("unknown option " + a);
  }
  if (o.reference.empty() || o.target.empty() || o.output.empty())
    return fail("--reference, --target and --output are required");
  return true;
}

struct Sampled {
  pcl::PointCloud<pcl::PointXYZ>::Ptr points{new pcl::PointCloud<pcl::PointXYZ>};
  pcl::PointCloud<pcl::Normal>::Ptr normals{new pcl::PointCloud<pcl::Normal>};
};

// Area-weighted random sampling: about area / spacing^2 points, each with its triangle's normal.
Sampled sample_mesh(const fe::TriangleMesh& m, double spacing, std::mt19937& rng) {
  const auto nt = static_cast<std::size_t>(m.triangles.rows());
  std::vector<double> cum(nt);
  std::vector<Eigen::Vector3d> tri_n(nt);
  double total = 0;
  for (std::size_t t = 0; t < nt; ++t) {
    const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)).transpose();
    const Eigen::Vector3d b = m.vertices.row(m.triangles(t, 1)).transpose();
    const Eigen::Vector3d c = m.vertices.row(m.triangles(t, 2)).transpose();
    const Eigen::Vector3d cr = (b - a).cross(c - a);
    const double area = 0.5 * cr.norm();
    tri_n[t] = area > 0 ? Eigen::Vector3d(cr.normalized()) : Eigen::Vector3d::UnitZ();
    total += area;
    cum[t] = total;
  }
  Sampled s;
  if (nt == 0 || !(total > 0)) return s;
  const auto n = static_cast<std::size_t>(std::clamp(total / (spacing * spacing), 100.0, 5e6));
  std::uniform_real_distribution<double> u(0.0, 1.0);
  s.points->reserve(n);
  s.normals->reserve(n);
  for (std::size_t i = 0; i < n; ++i) {
    const double r = u(rng) * total;
    std::size_t t = static_cast<std::size_t>(std::lower_bound(cum.begin(), cum.end(), r) - cum.begin());
    t = std::min(t, nt - 1);
    double r1 = u(rng), r2 = u(rng);
    if (r1 + r2 > 1) { r1 = 1 - r1; r2 = 1 - r2; }
    const Eigen::Vector3d a = m.vertices.row(m.triangles(t, 0)).transpose();
    const Eigen::Vector3d b = m.vertices.row(m.triangles(t, 1)).transpose();
    const Eigen::Vector3d c = m.vertices.row(m.triangles(t, 2)).transpose();
    const Eigen::Vector3d p = a + r1 * (b - a) + r2 * (c - a);
    s.points->push_back(pcl::PointXYZ(float(p.x()), float(p.y()), float(p.z())));
    pcl::Normal nn;
    nn.normal_x = float(tri_n[t].x());
    nn.normal_y = float(tri_n[t].y());
    nn.normal_z = float(tri_n[t].z());
    nn.curvature = 0;
    s.normals->push_back(nn);
  }
  return s;
}

pcl::PointCloud<pcl::PointXYZ>::Ptr keypoints(const pcl::PointCloud<pcl::PointXYZ>::Ptr& cloud, double radius) {
  pcl::PointCloud<pcl::PointXYZ>::Ptr out(new pcl::PointCloud<pcl::PointXYZ>);
  pcl::UniformSampling<pcl::PointXYZ> us;
  us.setInputCloud(cloud);
  us.setRadiusSearch(radius);
  us.filter(*out);
  return out;
}

pcl::PointCloud<pcl::SHOT352>::Ptr shot(const pcl::PointCloud<pcl::PointXYZ>::Ptr& kp, const Sampled& s,
                                         double radius, int threads) {
  pcl::PointCloud<pcl::SHOT352>::Ptr out(new pcl::PointCloud<pcl::SHOT352>);
  pcl::SHOTEstimationOMP<pcl::PointXYZ, pcl::Normal, pcl::SHOT352> est;
  est.setNumberOfThreads(static_cast<unsigned>(threads));
  est.setRadiusSearch(radius);
  est.setInputCloud(kp);
  est.setInputNormals(s.normals);
  est.setSearchSurface(s.points);
  est.compute(*out);
  return out;
}

pcl::PointCloud<pcl::ReferenceFrame>::Ptr board(const pcl::PointCloud<pcl::PointXYZ>::Ptr& kp, const Sampled& s,
                                                 double radius) {
  pcl::PointCloud<pcl::ReferenceFrame>::Ptr out(new pcl::PointCloud<pcl::ReferenceFrame>);
  pcl::BOARDLocalReferenceFrameEstimation<pcl::PointXYZ, pcl::Normal, pcl::ReferenceFrame> est;
  est.setFindHoles(true);
  est.setRadiusSearch(radius);
  est.setInputCloud(kp);
  est.setInputNormals(s.normals);
  est.setSearchSurface(s.points);
  est.compute(*out);
  return out;
}

void write_json_atomic(const nlohmann::json& j, const std::string& path) {
  const std::string tmp = path + ".tmp";
  {
    std::ofstream f(tmp);
    if (!f) throw std::runtime_error(path + ": cannot write");
    f << j.dump(1) << "\n";
    if (!f) throw std::runtime_error(path + ": write failed");
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) throw std::runtime_error(path + ": cannot rename " + tmp);
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (!parse_args(argc, argv, o)) return 2;
  // GC's per-group RANSAC prints "No samples could be selected!" for degenerate groups: not our errors.
  pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS);
  if (o.cg_size < 0) o.cg_size = o.hough ? 1.0 / 20 : 1.0 / 30;
  if (o.cg_thresh < 0) o.cg_thresh = o.hough ? 10 : 15;
  if (o.threads <= 0) o.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));

  const auto t_total = Clock::now();
  nlohmann::json timings;

  // Read. Target tessellation bounded by the feature's size, as our engine does.
  auto t = Clock::now();
  fe::TriangleMesh ref, tgt;
  try {
    ref = fe::read_shape(o.reference);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fe_pcl_peer: %s\n", e.what());
    return 3;
  }
  const double L = ref.diagonal();
  if (!(L > 0) || !std::isfinite(L)) {
    std::fprintf(stderr, "fe_pcl_peer: %s: reference has zero size\n", o.reference.c_str());
    return 3;
  }
  try {
    tgt = fe::read_shape(o.target, fe::tessellation_for_feature(L));
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fe_pcl_peer: %s\n", e.what());
    return 3;
  }
  timings["read"] = since(t);

  try {
    // Sampling and normals.
    t = Clock::now();
    std::mt19937 rng(o.seed);
    Sampled model = sample_mesh(ref, o.spacing * L, rng);
    Sampled scene = sample_mesh(tgt, o.spacing * L, rng);
    if (o.pcl_normals) {
      for (Sampled* s : {&model, &scene}) {
        pcl::NormalEstimationOMP<pcl::PointXYZ, pcl::Normal> ne;
        ne.setNumberOfThreads(static_cast<unsigned>(o.threads));
        ne.setKSearch(o.normal_k);
        ne.setInputCloud(s->points);
        ne.compute(*s->normals);  // oriented towards the default viewpoint (origin), as in the tutorial
      }
    }
    timings["normals"] = since(t);

    t = Clock::now();
    auto model_kp = keypoints(model.points, o.model_ss * L);
    auto scene_kp = keypoints(scene.points, o.scene_ss * L);
    timings["keypoints"] = since(t);

    t = Clock::now();
    auto model_d = shot(model_kp, model, o.descr_rad * L, o.threads);
    auto scene_d = shot(scene_kp, scene, o.descr_rad * L, o.threads);
    timings["shot"] = since(t);

    // Correspondences: nearest model descriptor for each scene descriptor, squared distance < corr_max.
    t = Clock::now();
    pcl::CorrespondencesPtr corrs(new pcl::Correspondences);
    {
      pcl::KdTreeFLANN<pcl::SHOT352> match;
      pcl::PointCloud<pcl::SHOT352>::Ptr valid_model(new pcl::PointCloud<pcl::SHOT352>);
      std::vector<int> valid_index;
      for (std::size_t i = 0; i < model_d->size(); ++i)
        if (std::isfinite((*model_d)[i].descriptor[0])) {
          valid_model->push_back((*model_d)[i]);
          valid_index.push_back(static_cast<int>(i));
        }
      if (!valid_model->empty()) {
        match.setInputCloud(valid_model);
        std::vector<int> idx(1);
        std::vector<float> d2(1);
        for (std::size_t i = 0; i < scene_d->size(); ++i) {
          if (!std::isfinite((*scene_d)[i].descriptor[0])) continue;
          if (match.nearestKSearch((*scene_d)[i], 1, idx, d2) == 1 && d2[0] < o.corr_max)
            corrs->push_back(pcl::Correspondence(valid_index[idx[0]], static_cast<int>(i), d2[0]));
        }
      }
    }
    timings["match"] = since(t);

    // Grouping.
    t = Clock::now();
    std::vector<Eigen::Matrix4f, Eigen::aligned_allocator<Eigen::Matrix4f>> rts;
    std::vector<pcl::Correspondences> clustered;
    if (!corrs->empty()) {
      if (o.hough) {
        auto model_rf = board(model_kp, model, o.rf_rad * L);
        auto scene_rf = board(scene_kp, scene, o.rf_rad * L);
        pcl::Hough3DGrouping<pcl::PointXYZ, pcl::PointXYZ, pcl::ReferenceFrame, pcl::ReferenceFrame> cg;
        cg.setHoughBinSize(o.cg_size * L);
        cg.setHoughThreshold(o.cg_thresh);
        cg.setUseInterpolation(true);
        cg.setUseDistanceWeight(false);
        cg.setInputCloud(model_kp);
        cg.setInputRf(model_rf);
        cg.setSceneCloud(scene_kp);
        cg.setSceneRf(scene_rf);
        cg.setModelSceneCorrespondences(corrs);
        cg.recognize(rts, clustered);
      } else {
        pcl::GeometricConsistencyGrouping<pcl::PointXYZ, pcl::PointXYZ> cg;
        cg.setGCSize(o.cg_size * L);
        cg.setGCThreshold(static_cast<int>(o.cg_thresh));
        cg.setInputCloud(model_kp);
        cg.setSceneCloud(scene_kp);
        cg.setModelSceneCorrespondences(corrs);
        cg.recognize(rts, clustered);
      }
    }

    // Instances, most correspondences first; drop duplicates (mapped centers closer than dedup * L).
    const Eigen::Vector3d lo = ref.vertices.colwise().minCoeff().transpose();
    const Eigen::Vector3d hi = ref.vertices.colwise().maxCoeff().transpose();
    const Eigen::Vector3d c_ref = 0.5 * (lo + hi);
    struct Inst {
      Eigen::Matrix4d T;
      Eigen::Vector3d center;
      std::size_t n;
    };
    std::vector<Inst> all;
    for (std::size_t i = 0; i < rts.size(); ++i) {
      const Eigen::Matrix4d T = rts[i].cast<double>();
      if (!T.allFinite()) continue;
      const Eigen::Vector3d c = T.topLeftCorner<3, 3>() * c_ref + T.topRightCorner<3, 1>();
      all.push_back({T, c, i < clustered.size() ? clustered[i].size() : 0});
    }
    std::stable_sort(all.begin(), all.end(), [](const Inst& a, const Inst& b) { return a.n > b.n; });
    std::vector<Inst> kept;
    for (const Inst& a : all) {
      bool dup = false;
      for (const Inst& k : kept) dup = dup || (a.center - k.center).norm() < o.dedup * L;
      if (!dup) kept.push_back(a);
    }
    timings["grouping"] = since(t);

    nlohmann::json matches = nlohmann::json::array();
    for (const Inst& k : kept) {
      nlohmann::json T = nlohmann::json::array();
      for (int r = 0; r < 4; ++r) T.push_back({k.T(r, 0), k.T(r, 1), k.T(r, 2), k.T(r, 3)});
      matches.push_back({{"transform", T},
                         {"correspondences", k.n},
                         {"center", {k.center.x(), k.center.y(), k.center.z()}}});
    }
    timings["total"] = since(t_total);

    nlohmann::json params = {
        {"reference_diagonal", L},
        {"seed", o.seed},
        {"threads", o.threads},
        {"normals", o.pcl_normals ? "NormalEstimationOMP k=" + std::to_string(o.normal_k) + ", viewpoint-oriented"
                                  : std::string("sampled triangle normals")},
        {"sampling_spacing", o.spacing * L},
        {"model_ss", o.model_ss * L},
        {"scene_ss", o.scene_ss * L},
        {"descr_rad", o.descr_rad * L},
        {"cg_size", o.cg_size * L},
        {"cg_thresh", o.cg_thresh},
        {"corr_max_sq_dist", o.corr_max},
        {"dedup_distance", o.dedup * L},
        {"relative_to_L",
         {{"spacing", o.spacing}, {"model_ss", o.model_ss}, {"scene_ss", o.scene_ss}, {"descr_rad", o.descr_rad},
          {"cg_size", o.cg_size}, {"dedup", o.dedup}}},
        {"counts",
         {{"model_points", model.points->size()},
          {"scene_points", scene.points->size()},
          {"model_keypoints", model_kp->size()},
          {"scene_keypoints", scene_kp->size()},
          {"correspondences", corrs->size()},
          {"groups_before_dedup", rts.size()}}},
    };
    if (o.hough) {
      params["rf_rad"] = o.rf_rad * L;
      params["relative_to_L"]["rf_rad"] = o.rf_rad;
    }

    nlohmann::json out = {{"method", o.hough ? "pcl-shot-hough" : "pcl-shot-gc"},
                          {"matches", matches},
                          {"timings", timings},
                          {"parameters", params}};
    write_json_atomic(out, o.output);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fe_pcl_peer: %s\n", e.what());
    return 1;
  }
  return 0;
}
