// A fixed-size, allocation-free Levenberg–Marquardt solver for per-texel fits, one instance
// per thread. The normal equations come either from the problem's own structured
// `Linearise` (when it has one) or from forward-mode autodiff (ceres::Jet, header only)
// through the problem's templated residuals — the same shading functions that render the data.
#pragma once

#include <ceres/jet.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <algorithm>
#include <array>
#include <cmath>

namespace matfit::fit {

struct LmSummary {
  int iterations = 0;
  double initial_cost = 0, final_cost = 0;  // ½ Σ r² (or the Cauchy cost)
  bool converged = false;  // stopped by a tolerance or the EDM rule, not the iteration cap
};

struct LmOptions {
  int max_iterations = 50;
  double function_tolerance = 1e-8;   // stop when Δcost < tol · cost
  double gradient_tolerance = 1e-12;  // stop when max |Jᵀr| < tol
  double step_tolerance = 1e-10;      // stop when |δ| < tol · (|x| + tol)
  double initial_lambda = 1e-3;
  // > 0: Cauchy loss ρ(r²) = σ² ln(1 + r²/σ²) with this σ (in residual units) instead of r², by
  // iteratively reweighted normal equations (weight 1/(1 + r²/σ²) from the current residual).
  double cauchy_scale = 0;
  // Statistical convergence (MINUIT's EDM rule; used when residuals > P): also stop when the
  // estimated distance to the minimum — the decrease the undamped Gauss–Newton step predicts,
  // ½ gᵀ (JᵀJ)⁻¹ g with g = Jᵀr, whatever λ is (with confine_steps, that step kept in the box:
  // −δ·g − ½ δᵀ JᵀJ δ) — is below `edm` in χ² units. With m residuals
  // the noise variance is σ̂² = 2 cost / (m − P) (cost = ½ Σ r²) and a decrease Δ is 2Δ / σ̂² in
  // χ², so the rule is EDM < edm · cost / (m − P): the minimum lies less than √edm standard
  // errors of the parameters away (Mahalanobis, covariance σ̂² (JᵀJ)⁻¹) — 0.01 at the default,
  // TMinuit's (0.001 × tolerance 0.1). With the Cauchy loss, cost and JᵀWJ are the robust ones
  // (IRLS), so the distance is the reweighted problem's: approximate. On noise-free data most of
  // the cost is what the step removes, so the rule does not fire and the other tolerances end
  // the solve.
  int residuals = 0;
  double edm = 1e-4;
  // Steps (and the EDM rule's) kept within the problem's box by ConfineStep rather than clamped.
  bool confine_steps = true;
};

// The EDM rule's limit on EDM / cost: edm / (m − P), 0 (off) with m ≤ P residuals.
template <int P>
double EdmLimit(const LmOptions& o) {
  return o.residuals > P ? o.edm / double(o.residuals - P) : 0.0;
}

// The cost Σ ½ r² (σ² = 0) or Σ ½ σ² ln(1 + r²/σ²), and the IRLS weight of each residual,
// 1/(1 + r²/σ²) (1 without the loss). The Cauchy sum of logs is ln Π (1 + e_i), e_i = r_i²/σ²,
// kept as q = Π (1 + e_i) − 1 (q ← q + e + q·e), so a residual far below σ is not lost to the
// rounding of 1 + e; q is folded into the sum (log1p) before it can overflow. One log per many
// residuals instead of a log1p each, with a relative error of a few 1e-16 per term at any
// residual size. NaN/Inf residuals give a NaN/Inf cost.
class LmCost {
 public:
  explicit LmCost(double s2) : cauchy_(s2 > 0), s2_(s2), inv_s2_(s2 > 0 ? 1 / s2 : 0) {}
  // Adds r² to the cost; returns the residual's weight.
  double Add(double r2) {
    if (!cauchy_) {
      sum_ += 0.5 * r2;
      return 1;
    }
    const double e = r2 * inv_s2_;
    q_ += e + q_ * e;
    if (!(q_ < 1e100)) sum_ += std::log1p(q_), q_ = 0;
    return 1 / (1 + e);
  }
  double Value() const { return cauchy_ ? 0.5 * s2_ * (sum_ + std::log1p(q_)) : sum_; }

 private:
  bool cauchy_;
  double s2_, inv_s2_, sum_ = 0, q_ = 0;
};

// Weighted normal equations by autodiff: JᵀWJ (lower triangle and mirrored) and JᵀWr, with
// W the IRLS weights (LmCost) at x; returns the cost at x. The reference for any structured
// `Linearise`.
template <int P, typename Problem>
double LineariseByJets(const Problem& problem, const double* x, double s2,
                       Eigen::Matrix<double, P, P>* jtj, Eigen::Matrix<double, P, 1>* jtr) {
  using Jet = ceres::Jet<double, P>;
  Jet xj[P];
  for (int k = 0; k < P; ++k) xj[k] = Jet(x[k], k);
  jtj->setZero();
  jtr->setZero();
  LmCost cost(s2);
  problem.Residuals(xj, [&](const Jet& r) {
    const double w = cost.Add(r.a * r.a);
    // Plain fixed-size loops (Eigen's rankUpdate dispatches to a general kernel, slower here).
    for (int a = 0; a < P; ++a) {
      const double ja = w * r.v[a];
      (*jtr)[a] += ja * r.a;
      for (int b = 0; b <= a; ++b) (*jtj)(a, b) += ja * r.v[b];
    }
  });
  for (int a = 0; a < P; ++a)
    for (int b = 0; b < a; ++b) (*jtj)(b, a) = (*jtj)(a, b);
  return cost.Value();
}

// Keeps a step within the problem's box (Project clamps each parameter to an interval). Given δ
// minimising the model q(δ) = g·δ + ½ δᵀ a δ (a positive definite), when Project would change
// x + δ it replaces δ by q's minimiser over the box, by a primal active-set method from δ = 0
// (x is in the box): step towards the minimiser on the current face — the held parameters
// fixed, the others solving a_ff δ_f = −g_f − a_fh δ_h — stopping where a parameter meets its
// bound, which is then held; at a face's minimiser, release the held parameter whose multiplier
// (a δ + g)_k says q decreases into the box; stop when none does (the box's KKT point). Returns
// whether δ changed. Clamping alone kept the other components solved as if the parameter had
// moved on: a worse point the damping then undid, so a fit whose minimum lies on a bound (a lobe
// amplitude at 0) crawled to it over strings of rejected steps.
template <int P, typename Problem>
bool ConfineStep(const Problem& problem, const Eigen::Matrix<double, P, 1>& x,
                 const Eigen::Matrix<double, P, P>& a, const Eigen::Matrix<double, P, 1>& g,
                 Eigen::Matrix<double, P, 1>* delta) {
  using Vec = Eigen::Matrix<double, P, 1>;
  using Mat = Eigen::Matrix<double, P, P>;
  auto leaves = [&](const Vec& step, Vec* clamped) {  // Project(x + step) ≠ x + step
    *clamped = x + step;
    problem.Project(clamped->data());
    return *clamped != x + step;
  };
  Vec clamped;
  if (!delta->allFinite() || !leaves(*delta, &clamped)) return false;
  std::array<int, P> held{};  // 0: free; ±1: held on the bound it was moving towards (its sign)
  Vec d = Vec::Zero(), target = *delta;
  // Each pass holds or releases one parameter; 4P + 4 passes bound any cycling of ties.
  for (int pass = 0; pass < 4 * P + 4; ++pass) {
    leaves(target, &clamped);
    double alpha = 1;
    int block = -1;
    for (int k = 0; k < P; ++k)
      if (!held[k] && clamped[k] != x[k] + target[k]) {
        const double ak = std::max(0.0, (clamped[k] - x[k] - d[k]) / (target[k] - d[k]));
        if (ak < alpha) alpha = ak, block = k;
      }
    if (block >= 0) {
      held[block] = target[block] > d[block] ? 1 : -1;
      d += alpha * (target - d);
      d[block] = clamped[block] - x[block];
    } else {
      d = target;
      const Vec mu = a * d + g;  // ∂q/∂δ: held k is right while −μ_k points out of the box
      int release = -1;
      double worst = 0;
      for (int k = 0; k < P; ++k)
        if (held[k] && mu[k] * held[k] > worst) worst = mu[k] * held[k], release = k;
      if (release < 0) break;
      held[release] = 0;
    }
    Mat m = a;
    Vec fixed = Vec::Zero();
    for (int k = 0; k < P; ++k)
      if (held[k]) fixed[k] = d[k];
    Vec b = -g - a * fixed;
    for (int k = 0; k < P; ++k)
      if (held[k]) m.row(k).setZero(), m.col(k).setZero(), m(k, k) = 1, b[k] = 0;
    target = m.ldlt().solve(b) + fixed;
    if (!target.allFinite()) break;
  }
  *delta = d;
  return true;
}

// Problem concept: `static constexpr int kParams = P;`,
//   template <typename T> void Residuals(const T* x, Add&& add) const
// calling add(r) once per residual, and `void Project(double* x) const` clamping each parameter
// to its interval of the valid domain (a box: ConfineStep relies on it). Optionally `double
// Linearise(const double* x, double s2, Mat* jtj, Vec* jtr) const` with LineariseByJets' contract,
// exploiting the problem's sparsity.
//
// Every trial point is linearised at once (the residuals come with it, so the cost is the
// same pass): accepted steps — most of them from a lambert-robust start — cost one pass.
template <int P, typename Problem>
LmSummary SolveTinyLm(const Problem& problem, Eigen::Matrix<double, P, 1>* x_in,
                      const LmOptions& options = {}) {
  using Vec = Eigen::Matrix<double, P, 1>;
  using Mat = Eigen::Matrix<double, P, P>;
  Vec& x = *x_in;
  const double s2 = options.cauchy_scale * options.cauchy_scale;
  auto linearise = [&](const Vec& v, Mat* jtj, Vec* jtr) {
    if constexpr (requires { problem.Linearise(v.data(), s2, jtj, jtr); })
      return problem.Linearise(v.data(), s2, jtj, jtr);
    else
      return LineariseByJets<P>(problem, v.data(), s2, jtj, jtr);
  };
  LmSummary s;
  Mat jtj, trial_jtj;
  Vec jtr, trial_jtr;
  const double edm_limit = EdmLimit<P>(options);
  bool fresh = true;  // the EDM rule not yet tried at x
  double cost = linearise(x, &jtj, &jtr);
  s.initial_cost = cost;
  double lambda = options.initial_lambda;
  for (s.iterations = 0; s.iterations < options.max_iterations; ++s.iterations) {
    if (jtr.template lpNorm<Eigen::Infinity>() < options.gradient_tolerance) {
      s.converged = true;
      break;
    }
    if (edm_limit > 0 && fresh) {  // once per point: a rejected step leaves JᵀJ, Jᵀr as they were
      fresh = false;
      // The decrease the undamped Gauss–Newton step predicts within the box: ½ gᵀ (JᵀJ)⁻¹ g
      // when no bound is in its way.
      const Eigen::LDLT<Mat> gn(jtj);
      if (gn.info() == Eigen::Success && gn.isPositive()) {
        const Vec h = gn.solve(jtr);
        Vec step = -h;
        const double edm = options.confine_steps && ConfineStep<P>(problem, x, jtj, jtr, &step)
                               ? -step.dot(jtr) - 0.5 * step.dot(jtj * step)
                               : 0.5 * jtr.dot(h);
        if (edm >= 0 && edm < edm_limit * cost) {
          s.converged = true;
          break;
        }
      }
    }
    Mat a = jtj;
    for (int k = 0; k < P; ++k) a(k, k) += lambda * (jtj(k, k) + 1e-12);
    Vec delta = a.ldlt().solve(-jtr);
    if (options.confine_steps) ConfineStep<P>(problem, x, a, jtr, &delta);
    if (!delta.allFinite()) break;
    if (delta.norm() < options.step_tolerance * (x.norm() + options.step_tolerance)) {
      s.converged = true;
      break;
    }
    // Decrease the linear model predicts for this step; when even that is negligible the
    // iterate is converged (saves the string of rejected steps a stationary point costs).
    const double predicted = -delta.dot(jtr) - 0.5 * delta.dot(jtj * delta);
    if (!(predicted > options.function_tolerance * cost)) {
      s.converged = true;
      break;
    }
    Vec trial = x + delta;
    problem.Project(trial.data());
    const double trial_cost = linearise(trial, &trial_jtj, &trial_jtr);
    if (trial_cost < cost) {
      const bool small = cost - trial_cost < options.function_tolerance * cost;
      x = trial, jtj = trial_jtj, jtr = trial_jtr;
      cost = trial_cost, fresh = true;
      lambda = std::max(lambda * 0.3, 1e-12);
      if (small) {
        s.converged = true;
        break;
      }
    } else {
      lambda *= 10;
      if (lambda > 1e10) {
        s.converged = true;  // no descent direction left: at a (local) minimum
        break;
      }
    }
  }
  s.final_cost = cost;
  return s;
}

}  // namespace matfit::fit
