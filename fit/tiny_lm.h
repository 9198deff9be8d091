// A fixed-size, allocation-free Levenberg–Marquardt solver for per-texel fits, one instance
// per thread. Jacobians come from forward-mode autodiff (ceres::Jet, header only) through the
// same templated shading functions that render the data.
#pragma once

#include <ceres/jet.h>

#include <Eigen/Cholesky>
#include <Eigen/Core>
#include <cmath>

namespace matfit::fit {

struct LmSummary {
  int iterations = 0;
  double initial_cost = 0, final_cost = 0;  // ½ Σ r² (or the Cauchy cost)
  bool converged = false;                   // relative cost decrease fell below the tolerance
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
};

// Problem concept: `static constexpr int kParams = P;` and
//   template <typename T> void Residuals(const T* x, const Accumulate<T>& add) const
// calling add(r) once per residual; `void Project(double* x) const` clamps to the valid domain.
template <int P, typename Problem>
LmSummary SolveTinyLm(const Problem& problem, Eigen::Matrix<double, P, 1>* x_in,
                      const LmOptions& options = {}) {
  using Jet = ceres::Jet<double, P>;
  using Vec = Eigen::Matrix<double, P, 1>;
  using Mat = Eigen::Matrix<double, P, P>;
  Vec& x = *x_in;
  const double s2 = options.cauchy_scale * options.cauchy_scale;
  auto loss = [&](double r2) { return s2 > 0 ? 0.5 * s2 * std::log1p(r2 / s2) : 0.5 * r2; };
  auto weight = [&](double r2) { return s2 > 0 ? 1.0 / (1.0 + r2 / s2) : 1.0; };
  auto cost_at = [&](const Vec& v) {
    double c = 0;
    problem.Residuals(v.data(), [&](double r) { c += loss(r * r); });
    return c;
  };
  auto linearise = [&](const Vec& v, Mat* jtj, Vec* jtr) {
    Jet xj[P];
    for (int k = 0; k < P; ++k) xj[k] = Jet(v[k], k);
    jtj->setZero();
    jtr->setZero();
    double c = 0;
    problem.Residuals(xj, [&](const Jet& r) {  // accumulates JᵀJ (lower) and Jᵀr
      const double r2 = r.a * r.a, w = weight(r2);
      c += loss(r2);
      // Lower triangle of JᵀJ and Jᵀr; plain fixed-size loops (Eigen's rankUpdate dispatches to
      // a general product kernel, slower at this size).
      for (int a = 0; a < P; ++a) {
        const double ja = w * r.v[a];
        (*jtr)[a] += ja * r.a;
        for (int b = 0; b <= a; ++b) (*jtj)(a, b) += ja * r.v[b];
      }
    });
    for (int a = 0; a < P; ++a)  // mirror to the full matrix
      for (int b = 0; b < a; ++b) (*jtj)(b, a) = (*jtj)(a, b);
    return c;
  };
  LmSummary s;
  Mat jtj;
  Vec jtr;
  double cost = linearise(x, &jtj, &jtr);
  s.initial_cost = cost;
  double lambda = options.initial_lambda;
  for (s.iterations = 0; s.iterations < options.max_iterations; ++s.iterations) {
    if (jtr.template lpNorm<Eigen::Infinity>() < options.gradient_tolerance) {
      s.converged = true;
      break;
    }
    Mat a = jtj;
    for (int k = 0; k < P; ++k) a(k, k) += lambda * (jtj(k, k) + 1e-12);
    const Vec delta = a.ldlt().solve(-jtr);
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
    const double trial_cost = cost_at(trial);
    if (trial_cost < cost) {
      const bool small = cost - trial_cost < options.function_tolerance * cost;
      x = trial;
      lambda = std::max(lambda * 0.3, 1e-12);
      cost = linearise(x, &jtj, &jtr);
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
