// `blinn-phong` and `cook-torrance` (METHODS.md §4): nonlinear per-texel fits of
//   p_ic / I_ic = ρ_c max(0, n·l_i) + lobe(n, l_i, v)
// with the lobe from core/shading/shading.h (the functions that render the synthetic data),
// solved by the fixed-size Levenberg–Marquardt of tiny_lm.h, one solve per texel, initialised
// from lambert-robust. Parameters x = (p, q, ρ_r, ρ_g, ρ_b, s1, s2) with n = normalize(p, q, 1);
// Blinn–Phong s1 = k_s, s2 = ln e; Cook–Torrance s1 = F0, s2 = roughness. Samples that look
// cast-shadowed (observed < 0.5 × the initial diffuse prediction) are left out.
//
// By default the lobe shape (e or roughness) is one value per material, as in the seed method:
// stage 1 fits all 7 parameters per texel, the shape is the median over texels with a clear
// lobe (k_s or F0 above a tenth of its 90th percentile), and stage 2 refits the 6 per-texel
// parameters with that shape fixed. Sparse real light sets (12 lights) overfit a per-texel
// shape; FitOptions::per_texel_lobe keeps stage 1's result.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <type_traits>
#include <vector>

#include "core/shading/shading.h"
#include "fit/fit_common.h"
#include "fit/methods.h"
#include "fit/tiny_lm.h"

namespace matfit::fit {
namespace {

constexpr int kP = 7;

// kShared: the lobe shape is the fixed `shape` (6 parameters), else x[6] (7 parameters).
template <bool kShared>
struct TexelProblem {
  static constexpr int kParams = kShared ? 6 : 7;
  bool cook_torrance = false;
  double shape = 0;  // ln e or roughness when kShared
  int n = 0, channels = 3;
  const Vec3* lights = nullptr;
  const double* obs = nullptr;  // [i * channels + c], intensity-normalised
  const char* use = nullptr;    // per sample
  Vec3 view{0, 0, 1};

  template <typename T, typename Add>
  void Residuals(const T* x, Add&& add) const {
    const Vec3T<T> nn = Normalize(Vec3T<T>(x[0], x[1], T(1)));
    const Vec3T<T> v(T(view.x), T(view.y), T(view.z));
    for (int i = 0; i < n; ++i) {
      if (!use[i]) continue;
      const Vec3T<T> l(T(lights[i].x), T(lights[i].y), T(lights[i].z));
      using std::exp;
      const T sh = kShared ? T(shape) : x[kParams - 1];
      const T lobe = cook_torrance ? shading::CookTorranceSpecular(x[5], sh, nn, l, v)
                                   : shading::BlinnPhongSpecular(x[5], exp(sh), nn, l, v);
      for (int c = 0; c < channels; ++c)
        add(shading::Lambert(x[2 + c], nn, l) + lobe - T(obs[i * channels + c]));
    }
  }
  void Project(double* x) const {
    for (int c = 2; c < 5; ++c) x[c] = std::clamp(x[c], 0.0, 2.0);
    x[5] = std::clamp(x[5], 0.0, cook_torrance ? 1.0 : 10.0);
    if (!kShared)
      x[6] = cook_torrance ? std::clamp(x[6], 0.05, 1.0) : std::clamp(x[6], 0.0, std::log(2000.0));
  }
};

StatusOr<FitResult> FitSpecular(const LightStack& s, const FitOptions& o, bool cook_torrance) {
  const char* name = cook_torrance ? "cook-torrance" : "blinn-phong";
  auto init = FitLambertRobust(s, o);
  if (!init.ok())
    return Status(init.status().code(), std::string(name) + ": " + init.status().message());
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, cook_torrance ? ShadingModel::kCookTorrance : ShadingModel::kBlinnPhong, name, &r);
  r.status = init->status;
  MaterialMaps& m = r.maps;
  m.specular = Image(s.width(), s.height(), 1);
  (cook_torrance ? m.roughness : m.exponent) = Image(s.width(), s.height(), 1);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<Vec3> dirs(n);
  for (int i = 0; i < n; ++i) dirs[i] = s.lights()[i].direction;
  std::vector<int> iterations(size_t(s.plane_size()), 0);

  // Per-texel data and initial guess, shared by both stages.
  auto gather = [&](int64_t p, std::vector<double>& obs, std::vector<char>& use, double* x7) {
    const Vec3 n0(init->maps.normal.Plane(0)[p], init->maps.normal.Plane(1)[p],
                  init->maps.normal.Plane(2)[p]);
    double rho[3];
    for (int c = 0; c < 3; ++c) rho[c] = init->maps.albedo.Plane(c)[p];
    int used = 0;
    for (int i = 0; i < n; ++i) {
      double lum = 0, pred = 0;
      for (int c = 0; c < C; ++c) {
        obs[i * C + c] = double(s.Plane(i, c)[p]) * inv[i * C + c];
        lum += obs[i * C + c];
        pred += rho[C == 1 ? 0 : c] * std::max(0.0, Dot(n0, dirs[i]));
      }
      use[i] = !(pred > 0.02 * C && lum < 0.5 * pred);
      used += use[i];
    }
    const double nz = std::max(n0.z, 0.2);
    const double init7[7] = {n0.x / nz,
                             n0.y / nz,
                             rho[0],
                             rho[C == 1 ? 0 : 1],
                             rho[C == 1 ? 0 : 2],
                             cook_torrance ? 0.04 : 0.2,
                             cook_torrance ? 0.5 : std::log(20.0)};
    std::copy(init7, init7 + 7, x7);
    return used;
  };
  auto store = [&](int64_t p, const double* x, double shape) {
    const Vec3 nn = Normalize(Vec3(x[0], x[1], 1.0));
    for (int c = 0; c < 3; ++c) {
      m.normal.Plane(c)[p] = float(nn[c]);
      m.albedo.Plane(c)[p] = float(x[2 + (C == 1 ? 0 : c)]);
    }
    m.specular.Plane(0)[p] = float(x[5]);
    if (cook_torrance)
      m.roughness.Plane(0)[p] = float(shape);
    else
      m.exponent.Plane(0)[p] = float(std::exp(shape));
  };
  // Runs the per-texel solve of one stage over all ok texels.
  auto stage = [&](auto shared_tag, double shape) {
    constexpr bool kShared = decltype(shared_tag)::value;
    constexpr int P = TexelProblem<kShared>::kParams;
    return ForEachTile(s, o, [&](const Tile& t) {
      std::vector<double> obs(size_t(n) * C);
      std::vector<char> use(n);
      TexelProblem<kShared> prob;
      prob.cook_torrance = cook_torrance;
      prob.shape = shape;
      prob.n = n, prob.channels = C, prob.lights = dirs.data(), prob.obs = obs.data(),
      prob.use = use.data();
      prob.view = s.view_direction;
      for (int y = t.y0; y < t.y0 + t.height; ++y)
        for (int xx = t.x0; xx < t.x0 + t.width; ++xx) {
          const int64_t p = int64_t(y) * W + xx;
          if (r.status[p] != kTexelOk) continue;
          double x7[7];
          const int used = gather(p, obs, use, x7);
          if (used * C < P + 2) {
            r.status[p] = kTexelTooFewLights;
            continue;
          }
          if (kShared) {  // start stage 2 from stage 1's per-texel values
            x7[5] = m.specular.Plane(0)[p];
            const Vec3 n1(m.normal.Plane(0)[p], m.normal.Plane(1)[p], m.normal.Plane(2)[p]);
            const double nz = std::max(n1.z, 0.2);
            x7[0] = n1.x / nz, x7[1] = n1.y / nz;
            for (int c = 0; c < 3; ++c) x7[2 + c] = m.albedo.Plane(c)[p];
          }
          Eigen::Matrix<double, P, 1> x;
          for (int k = 0; k < P; ++k) x[k] = x7[k];
          prob.Project(x.data());
          const LmSummary sum = SolveTinyLm<P>(prob, &x);
          iterations[p] += sum.iterations;
          if (!x.allFinite()) {
            r.status[p] = kTexelNonFinite;
            continue;
          }
          store(p, x.data(), kShared ? shape : x[6]);
        }
    });
  };
  bool ok = stage(std::false_type{}, 0.0);
  if (ok && !o.per_texel_lobe) {
    // One lobe shape per material: median over texels with a clear lobe.
    std::vector<float> strength, shapes;
    for (int64_t p = 0; p < s.plane_size(); ++p)
      if (r.status[p] == kTexelOk) strength.push_back(m.specular.data()[p]);
    if (!strength.empty()) {
      std::nth_element(strength.begin(), strength.begin() + strength.size() * 9 / 10,
                       strength.end());
      const float clear = 0.1f * strength[strength.size() * 9 / 10];
      for (int64_t p = 0; p < s.plane_size(); ++p)
        if (r.status[p] == kTexelOk && m.specular.data()[p] > clear)
          shapes.push_back(cook_torrance ? m.roughness.data()[p] : std::log(m.exponent.data()[p]));
    }
    if (!shapes.empty()) {
      std::nth_element(shapes.begin(), shapes.begin() + shapes.size() / 2, shapes.end());
      const double shape = shapes[shapes.size() / 2];
      r.parameters[cook_torrance ? "roughness" : "exponent"] =
          cook_torrance ? shape : std::exp(shape);
      ok = stage(std::true_type{}, shape);
    } else {
      r.warnings.push_back("no texel shows a specular lobe; kept the per-texel fit");
    }
  }
  double it_sum = 0, count = 0;
  for (size_t p = 0; p < iterations.size(); ++p)
    if (r.status[p] == kTexelOk) it_sum += iterations[p], count += 1;
  r.parameters["mean_lm_iterations"] = count > 0 ? it_sum / count : 0;
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace

StatusOr<FitResult> FitBlinnPhong(const LightStack& s, const FitOptions& o) {
  return FitSpecular(s, o, false);
}
StatusOr<FitResult> FitCookTorrance(const LightStack& s, const FitOptions& o) {
  return FitSpecular(s, o, true);
}

}  // namespace matfit::fit
