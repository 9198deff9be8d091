// TexelProblem::Linearise eight lights at a time: the lobe and the Lambertian term from the same
// shading functions, evaluated on lanes (core/shading/lanes.h), with their derivatives in the
// lobe parameters; the normal-equation sums and the cost kept per lane and added at the end.
#include "core/shading/lanes.h"

#include <cmath>

#include "core/simd_clones.h"
#include "fit/lobe_problem.h"

namespace matfit::fit::lobe {
namespace {

using lanes::Dual;
using lanes::L8;
using lanes::Mask;

template <int G>
Dual<G> Broadcast(const ceres::Jet<double, G>& j) {
  Dual<G> d{L8(j.a)};
  for (int k = 0; k < G; ++k) d.v[k] = L8(j.v[k]);
  return d;
}

// Per lane l the cost of LmCost over the residuals of the lights i ≡ l (mod 8): Σ ½ r² or the
// Cauchy sum kept as Π (1 + e) − 1, folded into the sum before it can overflow.
struct LaneCost {
  bool cauchy;
  double s2, inv_s2;
  L8 sum, q;
  explicit LaneCost(double s) : cauchy(s > 0), s2(s), inv_s2(s > 0 ? 1 / s : 0) {}
  L8 Add(L8 r) {  // the residual's IRLS weight
    if (!cauchy) {
      sum = sum + L8(0.5) * r * r;
      return L8(1.0);
    }
    const L8 e = r * r * L8(inv_s2);
    q = q + e + q * e;
    Fold();  // as LmCost: before the next residual can overflow the product
    return L8(1.0) / (L8(1.0) + e);
  }
  // On lanes, without a call (which would keep q in memory across the loop): for q ≥ 1e100,
  // ln(1 + q) = ln q to rounding.
  void Fold() {
    const Mask big = !(q < L8(1e100));
    if (!lanes::Any(big)) return;
    sum = sum + Select(big, lanes::Log(q), L8(0.0));
    q = Select(big, L8(0.0), q);
  }
  double Value() const {
    if (!cauchy) return lanes::Sum(sum);
    double total = 0;
    for (int k = 0; k < 8; ++k) total += sum.v[k] + std::log1p(q.v[k]);
    return 0.5 * s2 * total;
  }
};

template <typename Lobe, bool kShared, int P>
[[gnu::always_inline]] inline double LanesImpl(const TexelProblem<Lobe, kShared>& pr,
                                               const double* x, double s2,
                                               Eigen::Matrix<double, P, P>* jtj,
                                               Eigen::Matrix<double, P, 1>* jtr) {
  using Problem = TexelProblem<Lobe, kShared>;
  constexpr int G = Problem::kLobeParams, A = Lobe::kAmps, S = Lobe::kShapes;
  using D = Dual<G>;
  const auto jets = pr.MakeJets(x);
  D amps[A], sh[S];
  for (int k = 0; k < A; ++k) amps[k] = Broadcast(jets.g[2 + k]);
  for (int k = 0; k < S; ++k) sh[k] = Broadcast(jets.sh[k]);
  const Vec3T<D> n(Broadcast(jets.n.x), Broadcast(jets.n.y), Broadcast(jets.n.z));
  const LightLanes& L = *pr.lanes;
  const bool views = !L.vx.empty();  // per sample, else pr.view for all
  Vec3T<L8> v(L8(pr.view.x), L8(pr.view.y), L8(pr.view.z));
  typename Problem::template NormalSums<L8> sums;
  LaneCost cost(s2);
  for (int i = 0; i < L.padded; i += 8) {
    Mask use;
    if (i + 8 <= pr.n) {  // eight use flags widened at once
      typedef char C8 __attribute__((vector_size(8)));
      C8 u;
      __builtin_memcpy(&u, pr.use + i, sizeof u);
      use.m = __builtin_convertvector(u, lanes::I8) != 0;
    } else {
      for (int k = 0; k < 8; ++k) use.m[k] = i + k < pr.n && pr.use[i + k] ? -1 : 0;
    }
    if (!lanes::Any(use)) continue;
    const Vec3T<L8> l(lanes::Load(&L.lx[i]), lanes::Load(&L.ly[i]), lanes::Load(&L.lz[i]));
    const Vec3T<L8> h(lanes::Load(&L.hx[i]), lanes::Load(&L.hy[i]), lanes::Load(&L.hz[i]));
    if (views) v = Vec3T<L8>(lanes::Load(&L.vx[i]), lanes::Load(&L.vy[i]), lanes::Load(&L.vz[i]));
    // Lanes of unused samples are zeroed before they reach a sum (their lobe may be NaN).
    const D lobe = Select(use, Lobe::Eval(amps, sh, n, l, v, h), D(0.0));
    const D d = Select(use, shading::Lambert(D(1.0), n, l), D(0.0));
    for (int c = 0; c < pr.channels; ++c) {
      const double rho = x[2 + c];
      const L8 o = lanes::Load(pr.obs_lanes + size_t(c) * L.padded + i);
      const L8 r = Select(use, L8(rho) * d.a + lobe.a - o, L8(0.0));
      sums.Add(c, rho, d, lobe, r, cost.Add(r));
    }
  }
  typename Problem::template NormalSums<double> total;
  for (int a = 0; a < G; ++a) {
    total.g[a] = lanes::Sum(sums.g[a]);
    for (int b = 0; b <= a; ++b) total.gg[a][b] = lanes::Sum(sums.gg[a][b]);
    for (int c = 0; c < 3; ++c) total.gr[c][a] = lanes::Sum(sums.gr[c][a]);
  }
  for (int c = 0; c < 3; ++c)
    total.rr[c] = lanes::Sum(sums.rr[c]), total.r[c] = lanes::Sum(sums.r[c]);
  Problem::Assemble(total, jtj, jtr);
  return cost.Value();
}

}  // namespace

// Built for AVX-512, AVX2 and the baseline; the loader picks the widest the CPU runs.
template <typename Lobe, bool kShared, int P>
MATFIT_CLONES_V4 __attribute__((flatten)) double LineariseLanes(
    const TexelProblem<Lobe, kShared>& problem, const double* x, double s2,
    Eigen::Matrix<double, P, P>* jtj, Eigen::Matrix<double, P, 1>* jtr) {
  return LanesImpl<Lobe, kShared, P>(problem, x, s2, jtj, jtr);
}

#define MATFIT_LOBE_LANES(LOBE, SHARED)                                              \
  template double LineariseLanes<LOBE, SHARED, TexelProblem<LOBE, SHARED>::kParams>( \
      const TexelProblem<LOBE, SHARED>&, const double*, double,                      \
      Eigen::Matrix<double, TexelProblem<LOBE, SHARED>::kParams,                     \
                    TexelProblem<LOBE, SHARED>::kParams>*,                           \
      Eigen::Matrix<double, TexelProblem<LOBE, SHARED>::kParams, 1>*);
MATFIT_LOBE_LANES(BlinnPhongLobe, false)
MATFIT_LOBE_LANES(BlinnPhongLobe, true)
MATFIT_LOBE_LANES(CookTorranceLobe, false)
MATFIT_LOBE_LANES(CookTorranceLobe, true)
MATFIT_LOBE_LANES(LafortuneLobes<1>, false)
MATFIT_LOBE_LANES(LafortuneLobes<1>, true)
MATFIT_LOBE_LANES(LafortuneLobes<2>, false)
MATFIT_LOBE_LANES(LafortuneLobes<2>, true)
#undef MATFIT_LOBE_LANES

}  // namespace matfit::fit::lobe
