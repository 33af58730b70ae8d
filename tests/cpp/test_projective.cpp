// The projective solver of eqs. (3.2)-(3.4) and RANSAC (issue 2 tests).
#include "featureextract/geometry.h"
#include "../../core/src/kdtree.h"  // internal: the capped query RANSAC relies on

#include <gtest/gtest.h>

#include <atomic>
#include <limits>
#include <random>

namespace {

Eigen::Matrix4d known_H() {
  Eigen::Matrix4d H;
  H << 1.3, 0.2, -0.1, 5.0,  //
      -0.15, 0.9, 0.3, -2.0,  //
      0.05, -0.2, 1.6, 1.0,   //
      0.01, -0.02, 0.015, 1.0;
  return H;
}

fe::Points random_points(int n, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(-5, 5);
  fe::Points p(n, 3);
  for (int i = 0; i < n; ++i) p.row(i) << u(rng), u(rng), u(rng);
  return p;
}

fe::Points map(const Eigen::Matrix4d& H, const fe::Points& p) {
  fe::Points q(p.rows(), 3);
  for (Eigen::Index i = 0; i < p.rows(); ++i) q.row(i) = fe::apply_transform(H, p.row(i).transpose()).transpose();
  return q;
}

}  // namespace

TEST(Projective, RecoversKnownTransformFromFiveExactPairs) {
  std::mt19937 rng(3);
  const Eigen::Matrix4d H = known_H();
  const fe::Points r = random_points(5, rng);
  const fe::Points t = map(H, r);
  Eigen::Matrix4d E;
  ASSERT_TRUE(fe::solve_projective_5(r, t, E));
  EXPECT_NEAR(E(3, 3), 1.0, 1e-12);
  EXPECT_LT((E - H).norm(), 1e-6 * H.norm());
}

TEST(Projective, RejectsCoplanarSample) {
  fe::Points r(5, 3);
  r << 0, 0, 0, 1, 0, 0, 0, 1, 0, 1, 1, 0, 0.3, 0.7, 0;  // all in z = 0
  Eigen::Matrix4d E;
  EXPECT_FALSE(fe::solve_projective_5(r, map(known_H(), r), E));
}

TEST(Projective, LeastSquaresAndAffine) {
  std::mt19937 rng(5);
  const fe::Points r = random_points(40, rng);
  Eigen::Matrix4d E;
  ASSERT_TRUE(fe::fit_projective(r, map(known_H(), r), E));
  EXPECT_LT((E - known_H()).norm(), 1e-6);
  Eigen::Matrix4d A = known_H();
  A.row(3) << 0, 0, 0, 1;
  ASSERT_TRUE(fe::fit_affine(r, map(A, r), E));
  EXPECT_LT((E - A).norm(), 1e-8);
}

TEST(Projective, DeformationMeasures) {
  Eigen::Matrix4d S = Eigen::Matrix4d::Identity();
  S(0, 0) = 2.0;
  S(1, 1) = 0.5;
  const fe::Deformation d = fe::deformation(S, Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1));
  EXPECT_NEAR(d.volume_ratio, 1.0, 1e-12);
  EXPECT_NEAR(d.scale_max, 2.0, 1e-12);
  EXPECT_NEAR(d.scale_min, 0.5, 1e-12);
  EXPECT_NEAR(d.perspective, 0.0, 1e-12);
  EXPECT_FALSE(d.reflection);
  S(2, 2) = -1;
  EXPECT_TRUE(fe::deformation(S, Eigen::Vector3d(-1, -1, -1), Eigen::Vector3d(1, 1, 1)).reflection);
}

TEST(Ransac, RecoversTransformWithHalfThePairsWrong) {
  std::mt19937 rng(11);
  const Eigen::Matrix4d H = known_H();
  const int n = 60;
  const fe::Points r = random_points(n, rng);
  fe::Points t = map(H, r);
  std::uniform_real_distribution<double> u(-8, 8);
  for (int i = 0; i < n; i += 2) t.row(i) << u(rng), u(rng), u(rng);  // 50 % outliers
  // Cost: 40th percentile of the residuals over all pairs (robust with half the pairs wrong,
  // independent of the RANSAC internals).
  const int q = 2 * n / 5;
  auto cost = [&](const Eigen::Matrix4d& E) {
    std::vector<double> e;
    for (int i = 0; i < n; ++i) e.push_back((fe::apply_transform(E, r.row(i).transpose()) - t.row(i).transpose()).norm());
    std::nth_element(e.begin(), e.begin() + q, e.end());
    return e[q];
  };
  fe::RansacOptions o;
  o.seed = 1;
  o.max_iterations = 3000;
  o.patience = 1000;
  const fe::RansacResult res = fe::ransac_projective(r, t, cost, o);
  ASSERT_TRUE(res.found);
  EXPECT_LT(res.cost, 1e-6);
  EXPECT_LT((res.H - H).norm(), 1e-5 * H.norm());
  // same seed, same answer
  const fe::RansacResult again = fe::ransac_projective(r, t, cost, o);
  EXPECT_EQ(res.H, again.H);
  EXPECT_EQ(res.iterations, again.iterations);
}

// Scoring a batch of hypotheses on all threads (RansacOptions::batch) changes the time only: the
// same samples, the same stopping iteration and the same transform as one at a time, also with a
// cost that stops early past the best so far.
TEST(Ransac, BatchedScoringOnAllThreadsGivesTheSequentialResult) {
  std::mt19937 rng(11);
  const Eigen::Matrix4d H = known_H();
  const int n = 80;
  const fe::Points r = random_points(n, rng);
  fe::Points t = map(H, r);
  std::normal_distribution<double> noise(0, 0.01);
  std::uniform_real_distribution<double> u(-8, 8);
  for (int i = 0; i < n; ++i) {
    if (i % 3 == 0)
      t.row(i) << u(rng), u(rng), u(rng);  // a third outliers
    else
      t.row(i) += Eigen::RowVector3d(noise(rng), noise(rng), noise(rng));  // the rest noisy: the best keeps improving
  }
  std::atomic<int> calls{0};
  auto cost = [&](const Eigen::Matrix4d& E, double limit) {
    ++calls;
    double sum = 0;
    for (int i = 0; i < n; ++i) {
      sum += std::min(0.5, (fe::apply_transform(E, r.row(i).transpose()) - t.row(i).transpose()).norm());
      if (sum > limit * n) return std::numeric_limits<double>::infinity();  // cannot beat the best
    }
    return sum / n;
  };
  fe::RansacOptions o;
  o.seed = 3;
  o.max_iterations = 4000;
  o.patience = 150;
  const fe::RansacResult one = fe::ransac_projective(r, t, std::function<double(const Eigen::Matrix4d&, double)>(cost), o);
  ASSERT_TRUE(one.found);
  ASSERT_LT(one.iterations, o.max_iterations);  // stopped by patience, the case a batch must get right
  for (const int batch : {2, 16, 64}) {
    o.batch = batch;
    const fe::RansacResult b = fe::ransac_projective(r, t, std::function<double(const Eigen::Matrix4d&, double)>(cost), o);
    EXPECT_EQ(b.H, one.H) << "batch " << batch;
    EXPECT_EQ(b.cost, one.cost) << "batch " << batch;
    EXPECT_EQ(b.iterations, one.iterations) << "batch " << batch;
    EXPECT_EQ(b.sample, one.sample) << "batch " << batch;
  }
  EXPECT_GT(calls.load(), 3 * one.iterations / 2);  // the batches did run (four searches' worth of calls)
  // Stopped by the iteration bound instead, which no batch size divides: the next batch (drawn while
  // the one before is scored) must end at the bound too.
  o.patience = 1000000;
  o.max_iterations = 101;
  o.batch = 1;
  const fe::RansacResult bounded = fe::ransac_projective(r, t, std::function<double(const Eigen::Matrix4d&, double)>(cost), o);
  ASSERT_EQ(bounded.iterations, 101);
  for (const int batch : {2, 16, 64, 200}) {
    o.batch = batch;
    const fe::RansacResult b = fe::ransac_projective(r, t, std::function<double(const Eigen::Matrix4d&, double)>(cost), o);
    EXPECT_EQ(b.iterations, 101) << "batch " << batch;
    EXPECT_EQ(b.H, bounded.H) << "batch " << batch;
    EXPECT_EQ(b.sample, bounded.sample) << "batch " << batch;
  }
}

// The capped nearest-point query that RANSAC's cost uses: the very point nearest() gives whenever
// that one lies within the radius, and none otherwise.
TEST(KdTree, NearestWithinIsNearestOrNone) {
  std::mt19937 rng(5);
  const fe::Points p = random_points(3000, rng);
  const fe::KdTree3 tree(p);
  std::uniform_real_distribution<double> u(-3, 3), ur(0.01, 1.5);
  int within = 0, beyond = 0;
  for (int k = 0; k < 2000; ++k) {
    const Eigen::Vector3d q(u(rng), u(rng), u(rng));
    const double r = ur(rng);
    double d2 = 0, c2 = 0;
    const int j = tree.nearest(q, &d2);
    const int c = tree.nearest_within(q, r, &c2);
    if (d2 < r * r * (1 - 1e-6)) {
      ++within;
      EXPECT_EQ(c, j);
      EXPECT_EQ(c2, d2);
    } else if (d2 > r * r * (1 + 1e-6)) {
      ++beyond;
      EXPECT_EQ(c, -1);
    }
  }
  EXPECT_GT(within, 200);
  EXPECT_GT(beyond, 200);
  double d2 = 0;
  EXPECT_EQ(tree.nearest_within(Eigen::Vector3d(INFINITY, 0, 0), 1.0, &d2), -1);
}
