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
  template <typename T>
  static T Eval(const T* a, const T* shape, const Vec3T<T>& n, const Vec3& l, const Vec3& v,
                const Vec3& h) {
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
  template <typename T>
  static T Eval(const T* a, const T* s, const Vec3T<T>& n, const Vec3& l, const Vec3& v,
                const Vec3& h) {
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
  template <typename T>
  static T Eval(const T* a, const T* shape, const Vec3T<T>& n, const Vec3& l, const Vec3& v,
                const Vec3&) {
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
    constexpr int G = kLobeParams, A = Lobe::kAmps;
    using J = ceres::Jet<double, G>;
    int index[G];  // lobe parameter k → position in x
    J g[2 + A + Lobe::kShapes];
    for (int k = 0; k < G; ++k) index[k] = k < 2 ? k : k + 3;
    for (int k = 0; k < G; ++k) g[k] = J(x[index[k]], k);
    J fs[Lobe::kShapes], sh[Lobe::kShapes];
    for (int k = 0; k < Lobe::kShapes; ++k) fs[k] = kShared ? J(shape[k]) : g[2 + A + k];
    Lobe::Prepare(fs, sh);
    const Vec3T<J> nn = Normalize(Vec3T<J>(g[0], g[1], J(1)));
    double agg[G][G] = {}, agr[3][G] = {}, arr[3] = {}, bg[G] = {}, br[3] = {};
    LmCost cost(s2);
    for (int i = 0; i < n; ++i) {
      if (!use[i]) continue;
      // l, v, h are constants: plain doubles, so only n carries derivatives into the dots.
      const J lobe = Lobe::Eval(g + 2, sh, nn, lights[i], views ? views[i] : view, halves[i]);
      const J d = shading::Lambert(J(1), nn, lights[i]);
      for (int c = 0; c < channels; ++c) {
        const double rho = x[2 + c];
        const double r = rho * d.a + lobe.a - obs[i * channels + c];
        const double w = cost.Add(r * r), wr = w * r, wd = w * d.a;
        double u[G];
        for (int k = 0; k < G; ++k) u[k] = rho * d.v[k] + lobe.v[k];
        for (int a = 0; a < G; ++a) {
          const double wu = w * u[a];
          bg[a] += u[a] * wr;
          agr[c][a] += wd * u[a];
          for (int b = 0; b <= a; ++b) agg[a][b] += wu * u[b];
        }
        arr[c] += wd * d.a;
        br[c] += d.a * wr;
      }
    }
    jtj->setZero();
    jtr->setZero();
    for (int a = 0; a < G; ++a) {
      (*jtr)[index[a]] = bg[a];
      for (int b = 0; b <= a; ++b)
        (*jtj)(index[a], index[b]) = (*jtj)(index[b], index[a]) = agg[a][b];
    }
    for (int c = 0; c < 3; ++c) {
      (*jtr)[2 + c] = br[c];
      (*jtj)(2 + c, 2 + c) = arr[c];
      for (int a = 0; a < G; ++a) (*jtj)(2 + c, index[a]) = (*jtj)(index[a], 2 + c) = agr[c][a];
    }
    return cost.Value();
  }

  void Project(double* x) const {
    for (int c = 2; c < 5; ++c) x[c] = std::clamp(x[c], 0.0, 2.0);
    Lobe::Project(x + 5, kShared ? nullptr : x + 5 + Lobe::kAmps);
  }
};

}  // namespace matfit::fit::lobe
