// The structured normal equations of the nonlinear texel problems (lobe_problem.h) against
// autodiff of the same residuals over every parameter (LineariseByJets), and the solver's
// result with one against the other.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "fit/lobe_problem.h"
#include "fit/tiny_lm.h"

namespace matfit::fit {
namespace {

struct Samples {
  std::vector<Vec3> lights, halves;
  std::vector<double> obs;
  std::vector<char> use;
};

// n lights over the upper hemisphere, observations of an arbitrary texel with noise, a few
// samples switched off.
Samples MakeSamples(int n, int channels, std::mt19937* rng) {
  std::uniform_real_distribution<double> u(0, 1);
  Samples s;
  for (int i = 0; i < n; ++i) {
    const double th = std::acos(1 - 0.95 * u(*rng)), ph = 2 * M_PI * u(*rng);
    const Vec3 l(std::sin(th) * std::cos(ph), std::sin(th) * std::sin(ph), std::cos(th));
    s.lights.push_back(l);
    s.halves.push_back(Normalize(l + Vec3(0, 0, 1)));
    for (int c = 0; c < channels; ++c) s.obs.push_back(0.6 * u(*rng) * l.z + 0.05 * u(*rng));
    s.use.push_back(u(*rng) > 0.1);
  }
  return s;
}

// A texel problem over the samples at a random point: the lobe's shape (fixed with kShared) about
// its Init values, the normal's slopes in [−tilt, tilt], albedos and amplitudes about theirs.
template <typename Lobe, bool kShared>
struct RandomTexel {
  using Problem = lobe::TexelProblem<Lobe, kShared>;
  static constexpr int P = Problem::kParams;
  double shape[4] = {};
  Problem prob;
  Eigen::Matrix<double, P, 1> x;
  RandomTexel(const Samples& smp, int n, int channels, double tilt, std::mt19937* rng) {
    std::uniform_real_distribution<double> u(-1, 1);
    double a[Lobe::kAmps], sh[Lobe::kShapes];
    Lobe::Init(a, sh);
    for (int k = 0; k < Lobe::kShapes; ++k) shape[k] = sh[k] + 0.2 * u(*rng);
    prob.n = n, prob.channels = channels;
    prob.lights = smp.lights.data(), prob.halves = smp.halves.data();
    prob.obs = smp.obs.data(), prob.use = smp.use.data(), prob.shape = shape;
    x[0] = tilt * u(*rng), x[1] = tilt * u(*rng);
    for (int c = 2; c < 5; ++c) x[c] = 0.5 + 0.3 * u(*rng);
    for (int k = 0; k < Lobe::kAmps; ++k) x[5 + k] = a[k] * (1 + 0.5 * u(*rng));
    for (int k = 5 + Lobe::kAmps; k < P; ++k) x[k] = shape[k - 5 - Lobe::kAmps];
  }
  RandomTexel(const RandomTexel&) = delete;  // prob.shape points into it
};

// Two linearisations of one problem agree: the cost within cost_tol of the reference's, JᵀWJ and
// JᵀWr within tol of its largest JᵀWJ entry (at least 1), JᵀWJ symmetric.
template <int P>
void ExpectSameNormalEquations(double cost, const Eigen::Matrix<double, P, P>& jtj,
                               const Eigen::Matrix<double, P, 1>& jtr, double cost_ref,
                               const Eigen::Matrix<double, P, P>& jtj_ref,
                               const Eigen::Matrix<double, P, 1>& jtr_ref, double cost_tol,
                               double tol, int trial) {
  EXPECT_NEAR(cost, cost_ref, cost_tol * cost_ref) << "trial " << trial;
  const double scale = std::max(1.0, jtj_ref.cwiseAbs().maxCoeff());
  EXPECT_LT((jtj - jtj_ref).cwiseAbs().maxCoeff(), tol * scale) << "trial " << trial;
  EXPECT_LT((jtr - jtr_ref).cwiseAbs().maxCoeff(), tol * scale) << "trial " << trial;
  EXPECT_EQ(jtj, jtj.transpose());
}

template <typename Lobe, bool kShared>
void ExpectAgreement(int channels, double s2) {
  using Problem = lobe::TexelProblem<Lobe, kShared>;
  constexpr int P = Problem::kParams;
  std::mt19937 rng(7 + channels);
  for (int trial = 0; trial < 20; ++trial) {
    const Samples smp = MakeSamples(40, channels, &rng);
    RandomTexel<Lobe, kShared> t(smp, 40, channels, 0.3, &rng);
    const Problem& prob = t.prob;
    const auto& x = t.x;
    Eigen::Matrix<double, P, P> jtj_s, jtj_j;
    Eigen::Matrix<double, P, 1> jtr_s, jtr_j;
    const double cost_s = prob.template Linearise<P>(x.data(), s2, &jtj_s, &jtr_s);
    const double cost_j = LineariseByJets<P>(prob, x.data(), s2, &jtj_j, &jtr_j);
    ExpectSameNormalEquations<P>(cost_s, jtj_s, jtr_s, cost_j, jtj_j, jtr_j, 1e-13, 1e-12, trial);
    double direct = 0;  // the cost term by term
    prob.Residuals(x.data(), [&](double r) {
      direct += s2 > 0 ? 0.5 * s2 * std::log1p(r * r / s2) : 0.5 * r * r;
    });
    EXPECT_NEAR(cost_s, direct, 1e-12 * direct);
  }
}

// f.template operator()<Lobe, kShared>() for every texel problem of the lobe fits.
template <typename F>
void ForEachProblem(F&& f) {
  f.template operator()<lobe::BlinnPhongLobe, false>();
  f.template operator()<lobe::BlinnPhongLobe, true>();
  f.template operator()<lobe::CookTorranceLobe, false>();
  f.template operator()<lobe::CookTorranceLobe, true>();
  f.template operator()<lobe::LafortuneLobes<1>, false>();
  f.template operator()<lobe::LafortuneLobes<1>, true>();
  f.template operator()<lobe::LafortuneLobes<2>, false>();
  f.template operator()<lobe::LafortuneLobes<2>, true>();
}

// f(channels, σ²) for one and three channels, the plain and the Cauchy cost.
template <typename F>
void ForEachCase(F&& f) {
  for (double s2 : {0.0, 0.05 * 0.05})
    for (int channels : {1, 3}) {
      SCOPED_TRACE(testing::Message() << "channels " << channels << ", σ² " << s2);
      f(channels, s2);
    }
}

TEST(LmLinearise, StructuredNormalEquationsMatchAutodiff) {
  ForEachCase([](int channels, double s2) {
    ForEachProblem(
        [&]<typename Lobe, bool kShared>() { ExpectAgreement<Lobe, kShared>(channels, s2); });
  });
}

// The lane linearisation (eight lights at a time, fit/lobe_lanes.cc) against the structured one
// on doubles: the same sums in another order. 43 lights (a partial last group of eight),
// unused samples with NaN observations, normals toward and away from the lights. With
// `outliers`, every used observation is ±1e30 (e = r²/σ² ≈ 4e62 with σ = 0.05): each lane's
// Cauchy product passes 1e100 at every second residual and is folded into its sum (2–3 times
// even with one channel); unfolded, it would overflow within five residuals.
template <typename Lobe, bool kShared>
void ExpectLanesAgree(int channels, double s2, bool per_sample_views = false,
                      bool outliers = false) {
  using Problem = lobe::TexelProblem<Lobe, kShared>;
  constexpr int P = Problem::kParams;
  std::mt19937 rng(17 + channels);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    Samples smp = MakeSamples(43, channels, &rng);
    for (size_t i = 0; i < smp.use.size(); ++i)
      if (!smp.use[i]) smp.obs[i * channels] = std::nan("");
    for (size_t i = 0; outliers && i < smp.use.size(); ++i)
      for (int c = 0; c < channels && smp.use[i]; ++c)
        smp.obs[i * channels + c] = (i + c) % 2 ? 1e30 : -1e30;
    std::vector<Vec3> views;  // a multi-view stack's: each sample seen from its own direction
    for (int i = 0; per_sample_views && i < 43; ++i) {
      views.push_back(Normalize(Vec3(0.5 * u(rng), 0.5 * u(rng), 1)));
      smp.halves[size_t(i)] = Normalize(smp.lights[size_t(i)] + views.back());
    }
    const lobe::LightLanes lanes(smp.lights.data(), smp.halves.data(), 43,
                                 per_sample_views ? views.data() : nullptr);
    ASSERT_EQ(lanes.padded, 48);
    std::vector<double> obs_lanes(size_t(lanes.padded) * channels, 0.0);
    for (int i = 0; i < 43; ++i)
      for (int c = 0; c < channels; ++c)
        obs_lanes[c * lanes.padded + i] = smp.obs[i * channels + c];
    // Tilts up to 65°: some lights fall below the tilted surface's horizon.
    RandomTexel<Lobe, kShared> t(smp, 43, channels, 1.5, &rng);
    Problem& prob = t.prob;
    const auto& x = t.x;
    if (per_sample_views) prob.views = views.data();
    Eigen::Matrix<double, P, P> jtj_s, jtj_l;
    Eigen::Matrix<double, P, 1> jtr_s, jtr_l;
    const double cost_s = prob.template Linearise<P>(x.data(), s2, &jtj_s, &jtr_s);
    prob.lanes = &lanes, prob.obs_lanes = obs_lanes.data();
    const double cost_l = prob.template Linearise<P>(x.data(), s2, &jtj_l, &jtr_l);
    ASSERT_TRUE(std::isfinite(cost_s));
    ExpectSameNormalEquations<P>(cost_l, jtj_l, jtr_l, cost_s, jtj_s, jtr_s, 1e-13, 1e-13, trial);
  }
}

TEST(LmLinearise, EightLightsAtATimeMatchTheStructuredSums) {
  ForEachCase([](int channels, double s2) {
    ForEachProblem(
        [&]<typename Lobe, bool kShared>() { ExpectLanesAgree<Lobe, kShared>(channels, s2); });
    ExpectLanesAgree<lobe::CookTorranceLobe, false>(channels, s2, true);  // svbrdf's
    ExpectLanesAgree<lobe::BlinnPhongLobe, false>(channels, s2, true);
  });
}

TEST(LmLinearise, EightLightsAtATimeFoldTheCauchyProductLikeTheScalarCost) {
  for (int channels : {1, 3}) {
    SCOPED_TRACE(testing::Message() << "channels " << channels);
    ForEachProblem([&]<typename Lobe, bool kShared>() {
      ExpectLanesAgree<Lobe, kShared>(channels, 0.05 * 0.05, false, true);
    });
  }
}

TEST(LmLinearise, CauchyCostAsALogOfProductsMatchesTheSumOfLogs) {
  // Residuals up to 1e3 σ, so the running product must be folded many times.
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(0, 1);
  const double s2 = 0.05 * 0.05;
  LmCost cost(s2);
  double direct = 0;
  for (int i = 0; i < 5000; ++i) {
    const double r = 0.05 * std::pow(10.0, 3 * u(rng)) * (u(rng) - 0.5);
    cost.Add(r * r);
    direct += 0.5 * s2 * std::log1p(r * r / s2);
  }
  EXPECT_NEAR(cost.Value(), direct, 1e-12 * direct);
  // Near a perfect fit every residual is far below σ: 1 + r²/σ² would round to 1, and the
  // cost must still be exact to the last digits (LM compares such costs at 1e-8).
  for (double scale : {1e-3, 1e-5, 1e-9}) {
    LmCost tiny(s2);
    double want = 0;
    for (int i = 0; i < 243; ++i) {
      const double r = 0.05 * scale * (u(rng) - 0.5);
      tiny.Add(r * r);
      want += 0.5 * s2 * std::log1p(r * r / s2);
    }
    EXPECT_NEAR(tiny.Value(), want, 1e-13 * want) << "|r|/σ ≈ " << scale;
  }
  LmCost bad(s2);
  bad.Add(1.0);
  bad.Add(std::nan(""));
  EXPECT_TRUE(std::isnan(bad.Value()));
  LmCost plain(0);
  plain.Add(4.0), plain.Add(2.0);
  EXPECT_EQ(plain.Value(), 3.0);
}

// A problem without Linearise, so SolveTinyLm takes the autodiff path on the same residuals.
template <typename Inner>
struct JetsOnly {
  static constexpr int kParams = Inner::kParams;
  const Inner* inner;
  template <typename T, typename Add>
  void Residuals(const T* x, Add&& add) const {
    inner->Residuals(x, add);
  }
  void Project(double* x) const { inner->Project(x); }
};

TEST(LmLinearise, SolverReachesTheSameMinimumEitherWay) {
  using Problem = lobe::TexelProblem<lobe::BlinnPhongLobe, false>;
  constexpr int P = Problem::kParams;
  // A Blinn–Phong texel rendered by the shading functions, fitted from a perturbed start.
  std::mt19937 rng(3);
  Samples smp = MakeSamples(81, 3, &rng);
  const Vec3 n_true = Normalize(Vec3(0.2, -0.1, 1));
  const double rho[3] = {0.5, 0.3, 0.2}, ks = 0.4, e = 35;
  for (size_t i = 0; i < smp.lights.size(); ++i) {
    smp.use[i] = 1;
    const double lobe =
        shading::BlinnPhongSpecularHalf(ks, e, n_true, smp.lights[i], smp.halves[i]);
    for (int c = 0; c < 3; ++c)
      smp.obs[i * 3 + c] = shading::Lambert(rho[c], n_true, smp.lights[i]) + lobe;
  }
  Problem prob;
  // SolveTinyLm must find the structured path (else both solves below would be autodiff).
  static_assert(requires(const Problem& p, const double* x, Eigen::Matrix<double, P, P>* a,
                         Eigen::Matrix<double, P, 1>* b) { p.Linearise(x, 0.0, a, b); });
  prob.n = 81, prob.lights = smp.lights.data(), prob.halves = smp.halves.data();
  prob.obs = smp.obs.data(), prob.use = smp.use.data();
  Eigen::Matrix<double, P, 1> x0;
  x0 << 0.1, 0.0, 0.4, 0.4, 0.4, 0.2, std::log(20.0);
  LmOptions lm;
  lm.cauchy_scale = 0.05;
  Eigen::Matrix<double, P, 1> xs = x0, xj = x0;
  const LmSummary ss = SolveTinyLm<P>(prob, &xs, lm);
  const LmSummary sj = SolveTinyLm<P>(JetsOnly<Problem>{&prob}, &xj, lm);
  EXPECT_TRUE(ss.converged);
  EXPECT_EQ(ss.iterations, sj.iterations);
  EXPECT_LT((xs - xj).cwiseAbs().maxCoeff(), 1e-9);
  EXPECT_NEAR(xs[0], n_true.x / n_true.z, 1e-6);
  EXPECT_NEAR(xs[1], n_true.y / n_true.z, 1e-6);
  EXPECT_NEAR(std::exp(xs[6]), e, 1e-4 * e);
  EXPECT_NEAR(xs[5], ks, 1e-5);
}

// A Blinn–Phong texel (shape fixed: P = 6) under `lights` lights, Gaussian noise `sigma`, and
// a fraction `outliers` of its samples 0.3 too bright (a cast highlight, say).
struct NoisyBlinnPhong {
  using Problem = lobe::TexelProblem<lobe::BlinnPhongLobe, true>;
  static constexpr int P = Problem::kParams;
  Samples smp;
  double shape[1] = {std::log(35.0)};
  Problem prob;
  NoisyBlinnPhong(int lights, double sigma, double outliers, std::mt19937* rng) {
    smp = MakeSamples(lights, 3, rng);
    std::normal_distribution<double> noise(0, sigma);
    std::uniform_real_distribution<double> u(0, 1);
    const Vec3 n = Normalize(Vec3(0.2, -0.1, 1));
    const double rho[3] = {0.5, 0.3, 0.2};
    for (size_t i = 0; i < smp.lights.size(); ++i) {
      smp.use[i] = 1;
      const double lobe =
          shading::BlinnPhongSpecularHalf(0.4, 35.0, n, smp.lights[i], smp.halves[i]);
      const double outlier = u(*rng) < outliers ? 0.3 : 0.0;
      for (int c = 0; c < 3; ++c)
        smp.obs[i * 3 + c] =
            shading::Lambert(rho[c], n, smp.lights[i]) + lobe + outlier + noise(*rng);
    }
    prob.n = lights, prob.lights = smp.lights.data(), prob.halves = smp.halves.data();
    prob.obs = smp.obs.data(), prob.use = smp.use.data(), prob.shape = shape;
  }
  NoisyBlinnPhong(const NoisyBlinnPhong&) = delete;  // prob points into it
  // lambert-robust-like start: the normal a few degrees off, albedo near, the lobe at Init.
  Eigen::Matrix<double, P, 1> Start() const {
    Eigen::Matrix<double, P, 1> x;
    x << 0.25, -0.05, 0.45, 0.35, 0.2, 0.2;
    return x;
  }
};

// The EDM rule (LmOptions::residuals): with m residuals a solve stops once the minimum is within
// √edm = 0.01 standard errors. Against the same texel solved to a tolerance of 1e-14, the result
// must lie within 0.02 standard errors (Mahalanobis distance, covariance σ̂² (JᵀJ)⁻¹, σ̂² =
// Σ r² / (m − P); with the Cauchy loss and outliers the reweighted JᵀWJ and robust cost), after
// fewer trials than the same solve without the rule; on noise-free data it must not stop early.
TEST(TinyLm, TheEdmRuleStopsWithinAHundredthOfAStandardError) {
  using T = NoisyBlinnPhong;
  constexpr int P = T::P;
  std::mt19937 rng(11);
  for (double cauchy : {0.0, 0.05}) {
    int fewer = 0;
    for (int trial = 0; trial < 20; ++trial) {
      SCOPED_TRACE(testing::Message() << "Cauchy σ " << cauchy << ", trial " << trial);
      const int lights = trial % 2 ? 240 : 24;
      const T t(lights, 0.01, cauchy > 0 ? 0.1 : 0.0, &rng);
      const int m = lights * 3;
      LmOptions tight, plain, edm;
      tight.cauchy_scale = plain.cauchy_scale = edm.cauchy_scale = cauchy;
      tight.function_tolerance = 1e-14;
      edm.residuals = m;
      Eigen::Matrix<double, P, 1> x_ref = t.Start(), x_plain = t.Start(), x = t.Start();
      ASSERT_TRUE(SolveTinyLm<P>(t.prob, &x_ref, tight).converged);
      const LmSummary sp = SolveTinyLm<P>(t.prob, &x_plain, plain);
      const LmSummary s = SolveTinyLm<P>(t.prob, &x, edm);
      ASSERT_TRUE(s.converged);
      Eigen::Matrix<double, P, P> jtj;
      Eigen::Matrix<double, P, 1> jtr;
      const double cost = t.prob.Linearise<P>(x_ref.data(), cauchy * cauchy, &jtj, &jtr);
      const double var = 2 * cost / (m - P);
      const Eigen::Matrix<double, P, 1> d = x - x_ref;
      EXPECT_LT(std::sqrt(d.dot(jtj * d) / var), 0.02);
      EXPECT_GE(s.final_cost, cost * (1 - 1e-12));
      // The cost it stops at is within edm / 2 · σ̂² of the minimum's (plus the rounding).
      EXPECT_LT(s.final_cost - cost, 1e-4 * var);
      EXPECT_LE(s.iterations, sp.iterations);
      fewer += s.iterations < sp.iterations;
    }
    EXPECT_GE(fewer, 8) << "Cauchy σ " << cauchy;  // 9 and 15 of 20; 0 without the rule
  }
  // Noise-free: every step removes most of the cost left, so the rule never fires.
  const T exact(240, 0.0, 0.0, &rng);
  Eigen::Matrix<double, P, 1> x = exact.Start();
  LmOptions edm;
  edm.residuals = 240 * 3;
  ASSERT_TRUE(SolveTinyLm<P>(exact.prob, &x, edm).converged);
  const Vec3 n = Normalize(Vec3(0.2, -0.1, 1));
  EXPECT_NEAR(x[0], n.x / n.z, 1e-9);
  EXPECT_NEAR(x[1], n.y / n.z, 1e-9);
  EXPECT_NEAR(x[5], 0.4, 1e-9);
  // m ≤ P: no rule.
  LmOptions few;
  few.residuals = P;
  EXPECT_EQ(EdmLimit<P>(few), 0.0);
  few.residuals = P + 100;
  EXPECT_DOUBLE_EQ(EdmLimit<P>(few), 1e-6);
}

// A straight line through noisy points: linear, so EDM is exactly the cost above the minimum
// and the rule's threshold exact — a start 0.009 standard errors from the minimum is converged
// (no step taken), one 0.011 away is not.
struct NoisyLine {
  static constexpr int kParams = 2;
  std::vector<double> t, y;
  template <typename T, typename Add>
  void Residuals(const T* x, Add&& add) const {
    for (size_t i = 0; i < t.size(); ++i) add(x[0] + x[1] * t[i] - y[i]);
  }
  void Project(double*) const {}
};

TEST(TinyLm, TheEdmRuleFiresExactlyWithinItsDistance) {
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0, 0.02);
  NoisyLine line;
  for (int i = 0; i < 50; ++i)
    line.t.push_back(i / 49.0), line.y.push_back(0.3 + 0.5 * i / 49.0 + noise(rng));
  const int m = 50;
  Eigen::Matrix<double, 2, 1> best(0, 0);
  ASSERT_TRUE(SolveTinyLm<2>(line, &best).converged);
  Eigen::Matrix<double, 2, 2> jtj;
  Eigen::Matrix<double, 2, 1> jtr;
  const double var = 2 * LineariseByJets<2>(line, best.data(), 0.0, &jtj, &jtr) / (m - 2);
  for (Eigen::Matrix<double, 2, 1> u :
       {Eigen::Matrix<double, 2, 1>(1, 0), Eigen::Matrix<double, 2, 1>(0.3, -1)}) {
    u /= std::sqrt(u.dot(jtj * u) / var);  // one standard error along u
    for (double at : {0.009, 0.011}) {
      SCOPED_TRACE(testing::Message() << at << " standard errors along " << u.transpose());
      Eigen::Matrix<double, 2, 1> x = best + at * u;
      const Eigen::Matrix<double, 2, 1> start = x;
      LmOptions edm;
      edm.residuals = m;
      const LmSummary s = SolveTinyLm<2>(line, &x, edm);
      EXPECT_TRUE(s.converged);
      if (at < 0.01) {
        EXPECT_EQ(s.iterations, 0);
        EXPECT_EQ(x, start);
      } else {
        EXPECT_GE(s.iterations, 1);
        EXPECT_LT((x - best).norm(), 0.1 * (start - best).norm());
      }
    }
  }
}

// Two nearly collinear decays (like two lobes of similar shape) with the second amplitude held
// ≥ 0 by Project, on data whose unconstrained fit wants it negative: the bounded minimum is
// b = 0, a = Σ f₁y / Σ f₁². Steps confined to the box (ConfineStep) reach it in a few
// iterations; clamped steps (confine_steps off) crawl along the bound over rejected steps.
struct TwoDecays {
  static constexpr int kParams = 2;
  std::vector<double> t, y;
  static double F1(double t) { return std::exp(-t / 0.30); }
  static double F2(double t) { return std::exp(-t / 0.36); }
  template <typename T, typename Add>
  void Residuals(const T* x, Add&& add) const {
    for (size_t i = 0; i < t.size(); ++i) add(x[0] * F1(t[i]) + x[1] * F2(t[i]) - y[i]);
  }
  void Project(double* x) const { x[1] = std::max(x[1], 0.0); }
};

TEST(TinyLm, StepsConfinedToTheBoxReachAMinimumOnItsBound) {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0, 0.01);
  TwoDecays p;
  double f1y = 0, f1f1 = 0;
  for (int i = 0; i < 60; ++i) {
    const double t = i / 59.0;
    p.t.push_back(t), p.y.push_back(0.9 * TwoDecays::F1(t) - 0.3 * TwoDecays::F2(t) + noise(rng));
    f1y += TwoDecays::F1(t) * p.y.back(), f1f1 += TwoDecays::F1(t) * TwoDecays::F1(t);
  }
  // The unconstrained least-squares b is negative (else the bound would not matter).
  Eigen::Matrix<double, 2, 1> unconstrained(0.5, 0.5);
  struct Unbounded : TwoDecays {
    void Project(double*) const {}
  } unbounded{p};
  ASSERT_TRUE(SolveTinyLm<2>(unbounded, &unconstrained).converged);
  ASSERT_LT(unconstrained[1], -0.1);
  const double a_star = f1y / f1f1;
  for (bool edm : {false, true}) {
    SCOPED_TRACE(edm ? "with the EDM rule" : "without the EDM rule");
    LmOptions o;
    if (edm) o.residuals = int(p.t.size());
    Eigen::Matrix<double, 2, 1> x(0.5, 0.5);
    const LmSummary s = SolveTinyLm<2>(p, &x, o);
    EXPECT_TRUE(s.converged);
    EXPECT_EQ(x[1], 0.0);
    EXPECT_NEAR(x[0], a_star, edm ? 1e-3 : 1e-6);
    EXPECT_LE(s.iterations, 6);
    // The same solve with clamped steps: many more iterations (measured: 2 against the cap of 50,
    // still 1e-3 from a*).
    o.confine_steps = false;
    Eigen::Matrix<double, 2, 1> clamped(0.5, 0.5);
    const LmSummary c = SolveTinyLm<2>(p, &clamped, o);
    EXPECT_GT(c.iterations, 2 * s.iterations) << s.iterations << " vs " << c.iterations;
  }
}

// A box for ConfineStep: each parameter clamped to [lo_k, hi_k].
template <int P>
struct Box {
  static constexpr int kParams = P;
  Eigen::Matrix<double, P, 1> lo, hi;
  void Project(double* x) const {
    for (int k = 0; k < P; ++k) x[k] = std::clamp(x[k], lo[k], hi[k]);
  }
};

// ConfineStep against the box-constrained minimum of q(δ) = g·δ + ½ δᵀAδ found by enumerating
// every face (each parameter free, on its lower or on its upper bound: 3⁴ faces), on random
// strongly correlated positive definite A, gradients and points inside the box, including points
// on a bound. Also the two-bound case where fixing every parameter a step leaves the box by is
// wrong: A = [[1, −0.9], [−0.9, 1]], g = (−0.1, 1) at a corner x = (0, 0) of [0, 1]²: the
// unconstrained step leaves through both lower bounds, yet the minimum is (0.1, 0).
TEST(TinyLm, ConfinedStepsAreTheBoxesMinimumOfTheModel) {
  {
    Box<2> box{{0, 0}, {1, 1}};
    Eigen::Matrix2d a;
    a << 1, -0.9, -0.9, 1;
    const Eigen::Vector2d g(-0.1, 1), x(0, 0);
    Eigen::Vector2d d = a.ldlt().solve(-g);
    ASSERT_TRUE(ConfineStep<2>(box, x, a, g, &d));
    EXPECT_NEAR(d[0], 0.1, 1e-15);
    EXPECT_EQ(d[1], 0.0);
  }
  constexpr int P = 4;
  using Vec = Eigen::Matrix<double, P, 1>;
  using Mat = Eigen::Matrix<double, P, P>;
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(-1, 1);
  const Box<P> box{Vec::Constant(0), Vec::Constant(1)};
  int confined = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    Mat j;
    for (int r = 0; r < P; ++r)
      for (int c = 0; c < P; ++c) j(r, c) = u(rng) + (r == c ? 0.2 : 0.0) + 0.8 * (c == 0);
    const Mat a = j.transpose() * j + 1e-3 * Mat::Identity();
    Vec g, x;
    for (int k = 0; k < P; ++k) {
      g[k] = 2 * u(rng);
      const double v = u(rng);
      x[k] = v < -0.6 ? 0.0 : v > 0.6 ? 1.0 : 0.5 + 0.5 * v;  // some on a bound
    }
    auto q = [&](const Vec& d) { return g.dot(d) + 0.5 * d.dot(a * d); };
    double best = 0;  // δ = 0 is feasible
    for (int face = 0; face < 81; ++face) {
      int code[P], f = face;
      for (int k = 0; k < P; ++k) code[k] = f % 3, f /= 3;  // 0 free, 1 lower, 2 upper
      Mat m = a;
      Vec fixed = Vec::Zero();
      for (int k = 0; k < P; ++k)
        if (code[k]) fixed[k] = (code[k] == 1 ? 0.0 : 1.0) - x[k];
      Vec b = -g - a * fixed;
      for (int k = 0; k < P; ++k)
        if (code[k]) m.row(k).setZero(), m.col(k).setZero(), m(k, k) = 1, b[k] = 0;
      const Vec d = m.ldlt().solve(b) + fixed;
      Vec t = x + d;
      box.Project(t.data());
      if ((t - (x + d)).norm() < 1e-12) best = std::min(best, q(d));
    }
    Vec d = a.ldlt().solve(-g);
    const Vec free_step = d;
    if (ConfineStep<P>(box, x, a, g, &d)) {
      ++confined;
      Vec t = x + d;
      box.Project(t.data());
      EXPECT_LT((t - (x + d)).norm(), 1e-14) << "trial " << trial;
      EXPECT_NEAR(q(d), best, 1e-12 * (1 + std::abs(best))) << "trial " << trial;
    } else {
      EXPECT_EQ(d, free_step);
      EXPECT_NEAR(q(d), best, 1e-12 * (1 + std::abs(best))) << "trial " << trial;
    }
  }
  EXPECT_GT(confined, 1000);  // most trials meet a bound
}

}  // namespace
}  // namespace matfit::fit
