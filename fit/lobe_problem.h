// Per-texel problems of the nonlinear fits (specular_fit.cc, METHODS.md §4): the lobe traits
// and the texel residuals p_ic / I_ic − (ρ_c max(0, n·l_i) + lobe(n, l_i, v)), with the lobe
// from core/shading/shading.h. Internal to fit/; a header so the tests can compare the
// structured linearisation with autodiff of the same residuals.
#pragma once

#include <ceres/jet.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <map>
#include <string>
#include <vector>

#include "core/material_maps.h"
#include "core/shading/shading.h"
#include "fit/tiny_lm.h"

namespace matfit::fit::lobe {

using FitParameters = std::map<std::string, double>;

// Lobe traits: amplitudes a[kAmps], shape parameters s[kShapes] (in fitting coordinates).
struct BlinnPhongLobe {
  static constexpr int kAmps = 1, kShapes = 1;  // k_s; ln e
  static constexpr const char* kModel = "blinn-phong";
  // Fitted shape planes (ln e) → maps; the shared value as a model parameter.
  static void StoreShape(Image shape, FitParameters* params, MaterialMaps* m) {
    for (float& v : shape.data()) v = std::exp(v);
    m->exponent = std::move(shape);
    if (params->count("lobe_shape_0")) (*params)["exponent"] = std::exp((*params)["lobe_shape_0"]);
  }
  // Maps → fitting-coordinate shape planes (the inverse of StoreShape); empty when absent.
  static Image LoadShape(const MaterialMaps& m) {
    Image shape = m.exponent;
    for (float& v : shape.data()) v = std::log(std::max(v, 1e-30f));
    return shape;
  }
  template <typename T>
  static void Prepare(const T* s, T* shape) {  // fitting coordinates → model parameters
    using std::exp;
    shape[0] = exp(s[0]);
  }
  template <typename T, typename V>
  [[gnu::always_inline]] static T Eval(const T* a, const T* shape, const Vec3T<T>& n,
                                       const Vec3T<V>& l, const Vec3T<V>& v, const Vec3T<V>& h) {
    (void)v;
    return shading::BlinnPhongSpecularHalf(a[0], shape[0], n, l, h);
  }
  static void Init(double* a, double* s) { a[0] = 0.2, s[0] = std::log(20.0); }
  static void Project(double* a, double* s) {
    a[0] = std::clamp(a[0], 0.0, 10.0);
    if (s) s[0] = std::clamp(s[0], 0.0, std::log(2000.0));
  }
};

struct CookTorranceLobe {
  static constexpr int kAmps = 1, kShapes = 1;  // F0; roughness
  static constexpr const char* kModel = "cook-torrance";
  static void StoreShape(Image shape, FitParameters* params, MaterialMaps* m) {
    m->roughness = std::move(shape);
    if (params->count("lobe_shape_0")) (*params)["roughness"] = (*params)["lobe_shape_0"];
  }
  static Image LoadShape(const MaterialMaps& m) { return m.roughness; }
  template <typename T>
  static void Prepare(const T* s, T* shape) {
    shape[0] = s[0];
  }
  template <typename T, typename V>
  [[gnu::always_inline]] static T Eval(const T* a, const T* s, const Vec3T<T>& n, const Vec3T<V>& l,
                                       const Vec3T<V>& v, const Vec3T<V>& h) {
    return shading::CookTorranceSpecularHalf(a[0], s[0], n, l, v, h);
  }
  static void Init(double* a, double* s) { a[0] = 0.04, s[0] = 0.5; }
  static void Project(double* a, double* s) {
    a[0] = std::clamp(a[0], 0.0, 1.0);
    if (s) s[0] = std::clamp(s[0], 0.05, 1.0);
  }
};

template <int L>
struct LafortuneLobes {
  static constexpr int kAmps = L, kShapes = 2 * L;  // ρ_s,j; (C_xy,j, ln e_j)
  static constexpr const char* kModel = "lafortune";
  static void StoreShape(Image shape, FitParameters*, MaterialMaps* m) {
    for (int j = 0; j < L; ++j)
      for (float& v : shape.Plane(2 * j + 1)) v = std::exp(v);
    m->lobe_shape = std::move(shape);
  }
  static Image LoadShape(const MaterialMaps& m) {
    Image shape = m.lobe_shape;
    for (int j = 0; j < L && !shape.empty(); ++j)
      for (float& v : shape.Plane(2 * j + 1)) v = std::log(std::max(v, 1e-30f));
    return shape;
  }
  template <typename T>
  static void Prepare(const T* s, T* shape) {
    using std::exp;
    for (int j = 0; j < L; ++j) shape[2 * j] = s[2 * j], shape[2 * j + 1] = exp(s[2 * j + 1]);
  }
  template <typename T, typename V>
  [[gnu::always_inline]] static T Eval(const T* a, const T* shape, const Vec3T<T>& n,
                                       const Vec3T<V>& l, const Vec3T<V>& v, const Vec3T<V>&) {
    T r(0);
    for (int j = 0; j < L; ++j)
      r += shading::LafortuneLobe(a[j], shape[2 * j], shape[2 * j + 1], n, l, v);
    return r;
  }
  static void Init(double* a, double* s) {
    // Lobe 1: a mirror-like lobe; lobe 2: a broad retro-reflective one.
    for (int j = 0; j < L; ++j)
      a[j] = 0.1, s[2 * j] = j == 0 ? -1.0 : 0.5, s[2 * j + 1] = std::log(j == 0 ? 20.0 : 4.0);
  }
  static void Project(double* a, double* s) {
    for (int j = 0; j < L; ++j) {
      a[j] = std::clamp(a[j], 0.0, 10.0);
      if (s)
        s[2 * j] = std::clamp(s[2 * j], -3.0, 3.0),
              s[2 * j + 1] = std::clamp(s[2 * j + 1], 0.0, std::log(2000.0));
    }
  }
};

// A stack's lights and half vectors (and each sample's view, for multi-view stacks) in SoA,
// padded to a multiple of 8 (the padding's entries are 0 and never used): what TexelProblem's
// lane linearisation loads eight at a time.
struct LightLanes {
  int n = 0, padded = 0;
  std::vector<double> lx, ly, lz, hx, hy, hz;
  std::vector<double> vx, vy, vz;  // empty without per-sample views
  LightLanes(const Vec3* lights, const Vec3* halves, int count, const Vec3* views = nullptr)
      : n(count), padded((count + 7) / 8 * 8) {
    for (auto* v : {&lx, &ly, &lz, &hx, &hy, &hz}) v->assign(size_t(padded), 0.0);
    if (views)
      for (auto* v : {&vx, &vy, &vz}) v->assign(size_t(padded), 0.0);
    for (int i = 0; i < n; ++i) {
      lx[i] = lights[i].x, ly[i] = lights[i].y, lz[i] = lights[i].z;
      hx[i] = halves[i].x, hy[i] = halves[i].y, hz[i] = halves[i].z;
      if (views) vx[i] = views[i].x, vy[i] = views[i].y, vz[i] = views[i].z;
    }
  }
};

template <typename Lobe, bool kShared>
struct TexelProblem;
// TexelProblem::Linearise with eight lights at a time (fit/lobe_lanes.cc: the shading functions
// on lanes, AVX-512/AVX2 clones): the same normal equations and cost up to the order of the sums.
template <typename Lobe, bool kShared, int P>
double LineariseLanes(const TexelProblem<Lobe, kShared>& problem, const double* x, double s2,
                      Eigen::Matrix<double, P, P>* jtj, Eigen::Matrix<double, P, 1>* jtr);

// Texel problem: x = (p, q, ρ_r, ρ_g, ρ_b, amps…[, shapes…]); with kShared the shapes are fixed.
template <typename Lobe, bool kShared>
struct TexelProblem {
  static constexpr int kParams = 5 + Lobe::kAmps + (kShared ? 0 : Lobe::kShapes);
  // The lobe's own parameters: (p, q, amps…[, shapes…]); the albedos enter linearly.
  static constexpr int kLobeParams = kParams - 3;
  int n = 0, channels = 3;
  const Vec3* lights = nullptr;
  const Vec3* halves = nullptr;  // normalize(l_i + v), precomputed
  const double* obs = nullptr;   // [i * channels + c], intensity-normalised
  const char* use = nullptr;     // per sample
  Vec3 view{0, 0, 1};
  const Vec3* views = nullptr;    // per sample (multi-view stacks); null: `view` for all
  const double* shape = nullptr;  // kShared: the fixed shape parameters
  // Both set (with the same views as `views`, lanes->n == n): Linearise takes eight samples at
  // a time. obs_lanes holds the observations by channel, [c · lanes->padded + i], `padded` long
  // with 0 past n.
  const LightLanes* lanes = nullptr;
  const double* obs_lanes = nullptr;

  template <typename T, typename Add>
  void Residuals(const T* x, Add&& add) const {
    const Vec3T<T> nn = Normalize(Vec3T<T>(x[0], x[1], T(1)));
    T fs[Lobe::kShapes], sh[Lobe::kShapes];  // shape in fitting coordinates, then model units
    for (int k = 0; k < Lobe::kShapes; ++k) fs[k] = kShared ? T(shape[k]) : x[5 + Lobe::kAmps + k];
    Lobe::Prepare(fs, sh);
    for (int i = 0; i < n; ++i) {
      if (!use[i]) continue;
      const Vec3& l = lights[i];  // l, v, h: constants (h = normalize(l + v), precomputed)
      const T lobe = Lobe::Eval(x + 5, sh, nn, l, views ? views[i] : view, halves[i]);
      const T d = shading::Lambert(T(1), nn, l);  // max(0, n·l): ρ_c·d is Lambert(ρ_c, n, l)
      for (int c = 0; c < channels; ++c) add(x[2 + c] * d + lobe - T(obs[i * channels + c]));
    }
  }

  // Structured normal equations and cost (LineariseByJets' contract). With g the lobe parameters
  // and r_c = ρ_c d + L − o_c per sample: ∂r_c/∂g = ρ_c ∂d/∂g + ∂L/∂g =: u_c, ∂r_c/∂ρ_c = d, and
  // ∂r_c/∂ρ_c' = 0. So autodiff runs over the kLobeParams lobe parameters only (d and L from
  // the same shading functions), and the blocks are JᵀWJ_gg = Σ w u uᵀ, JᵀWJ_gρc = Σ w d u,
  // JᵀWJ_ρcρc = Σ w d², JᵀWr_g = Σ w r u, JᵀWr_ρc = Σ w d r.
  template <int P>
  [[gnu::flatten]] double Linearise(const double* x, double s2, Eigen::Matrix<double, P, P>* jtj,
                                    Eigen::Matrix<double, P, 1>* jtr) const {
    static_assert(P == kParams);
    if (lanes && obs_lanes && lanes->n == n && (views != nullptr) == !lanes->vx.empty())
      return LineariseLanes<Lobe, kShared, P>(*this, x, s2, jtj, jtr);
    using J = LobeJet;
    const LobeJets jets = MakeJets(x);
    NormalSums<double> sums;
    LmCost cost(s2);
    for (int i = 0; i < n; ++i) {
      if (!use[i]) continue;
      // l, v, h are constants: plain doubles, so only n carries derivatives into the dots.
      const J lobe =
          Lobe::Eval(jets.g + 2, jets.sh, jets.n, lights[i], views ? views[i] : view, halves[i]);
      const J d = shading::Lambert(J(1), jets.n, lights[i]);
      for (int c = 0; c < channels; ++c) {
        const double rho = x[2 + c];
        const double r = rho * d.a + lobe.a - obs[i * channels + c];
        sums.Add(c, rho, d, lobe, r, cost.Add(r * r));
      }
    }
    Assemble(sums, jtj, jtr);
    return cost.Value();
  }

  // The lobe parameters (p, q, amps…[, shapes…]) as Jets over themselves.
  using LobeJet = ceres::Jet<double, kLobeParams>;
  struct LobeJets {
    LobeJet g[2 + Lobe::kAmps + Lobe::kShapes];
    LobeJet sh[Lobe::kShapes];  // the shape in model units (fixed with kShared)
    Vec3T<LobeJet> n{LobeJet(0), LobeJet(0), LobeJet(0)};  // the unit normal
  };
  static constexpr int ParamIndex(int k) { return k < 2 ? k : k + 3; }  // lobe parameter k → x
  LobeJets MakeJets(const double* x) const {
    constexpr int G = kLobeParams, A = Lobe::kAmps;
    using J = LobeJet;
    LobeJets j;
    for (int k = 0; k < G; ++k) j.g[k] = J(x[ParamIndex(k)], k);
    J fs[Lobe::kShapes];
    for (int k = 0; k < Lobe::kShapes; ++k) fs[k] = kShared ? J(shape[k]) : j.g[2 + A + k];
    Lobe::Prepare(fs, j.sh);
    j.n = Normalize(Vec3T<J>(j.g[0], j.g[1], J(1)));
    return j;
  }

  // The blocks' sums over residuals, on doubles or on lanes (S): one residual r = ρ d + L − o of
  // channel c with IRLS weight w, d and L with their derivatives (.a, .v[k]) in the lobe
  // parameters.
  template <typename S>
  struct NormalSums {
    static constexpr int G = kLobeParams;
    S gg[G][G] = {}, gr[3][G] = {}, rr[3] = {}, g[G] = {}, r[3] = {};
    template <typename D>
    void Add(int c, double rho, const D& d, const D& lobe, S res, S w) {
      const S wr = w * res, wd = w * d.a;
      S u[G];
      for (int k = 0; k < G; ++k) u[k] = rho * d.v[k] + lobe.v[k];
      for (int a = 0; a < G; ++a) {
        const S wu = w * u[a];
        g[a] += u[a] * wr;
        gr[c][a] += wd * u[a];
        for (int b = 0; b <= a; ++b) gg[a][b] += wu * u[b];
      }
      rr[c] += wd * d.a;
      r[c] += d.a * wr;
    }
  };
  template <int P>
  static void Assemble(const NormalSums<double>& s, Eigen::Matrix<double, P, P>* jtj,
                       Eigen::Matrix<double, P, 1>* jtr) {
    constexpr int G = kLobeParams;
    jtj->setZero();
    jtr->setZero();
    for (int a = 0; a < G; ++a) {
      const int ia = ParamIndex(a);
      (*jtr)[ia] = s.g[a];
      for (int b = 0; b <= a; ++b)
        (*jtj)(ia, ParamIndex(b)) = (*jtj)(ParamIndex(b), ia) = s.gg[a][b];
    }
    for (int c = 0; c < 3; ++c) {
      (*jtr)[2 + c] = s.r[c];
      (*jtj)(2 + c, 2 + c) = s.rr[c];
      for (int a = 0; a < G; ++a)
        (*jtj)(2 + c, ParamIndex(a)) = (*jtj)(ParamIndex(a), 2 + c) = s.gr[c][a];
    }
  }

  void Project(double* x) const {
    for (int c = 2; c < 5; ++c) x[c] = std::clamp(x[c], 0.0, 2.0);
    Lobe::Project(x + 5, kShared ? nullptr : x + 5 + Lobe::kAmps);
  }
};

}  // namespace matfit::fit::lobe
