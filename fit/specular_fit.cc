// Nonlinear per-texel fits (METHODS.md §4): `blinn-phong`, `cook-torrance`, `lafortune1`,
// `lafortune2`. Model: p_ic / I_ic = ρ_c max(0, n·l_i) + lobe(n, l_i, v), the lobe from
// core/shading/shading.h (the functions that render the synthetic data). Each texel is solved
// by the fixed-size Levenberg–Marquardt of tiny_lm.h, initialised from lambert-robust, until the
// minimum is within 0.01 standard errors (its EDM rule, σ̂ from the texel's own residuals).
// Parameters: (p, q) with n = normalize(p, q, 1), ρ_r, ρ_g, ρ_b, then the lobe's amplitudes
// and shape parameters. Samples that look cast-shadowed (observed < 0.5 × the initial diffuse
// prediction), clipped or non-finite samples are left out.
//
// By default the lobe shape is one value per material, as in the seed method: stage 1 fits
// every parameter per texel on a regular grid of FitOptions::lobe_shape_texels to 2.25 × that many
// texels (every texel on smaller stacks); each shape parameter is then the median over those
// with a clear lobe (first amplitude above a tenth of its 90th percentile), and stage 2 fits
// normal, albedo and amplitudes of every texel with the shape fixed, from stage 1's result where
// there is one and from lambert-robust's elsewhere (also where stage 1 could not fit a texel).
// Sparse real light sets overfit a per-texel shape; FitOptions::per_texel_lobe keeps stage 1's
// result, on every texel. A given shape (FitOptions::lobe_shape) needs no stage 1.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <limits>
#include <type_traits>
#include <vector>

#include "core/shading/shading.h"
#include "core/stack_band.h"
#include "core/warnings.h"
#include "fit/fit_common.h"
#include "fit/lobe_problem.h"
#include "fit/methods.h"
#include "fit/tiny_lm.h"

namespace matfit::fit {
namespace {

// The median shape (fitting coordinates) over ok texels with a clear lobe: first amplitude above
// a tenth of its 90th percentile; only texels with only[p] ≠ 0 when `only` is given. Quantiles
// over the whole stack: a band of a distributed one gathers every band's values (a quantile does
// not depend on their order). False: no such texel.
bool MedianShape(const LightStack& s, const std::vector<uint8_t>& status, const float* strength,
                 const std::vector<const float*>& shapes, std::vector<double>* out,
                 const std::vector<char>* only = nullptr) {
  auto ok = [&](int64_t p) { return status[p] == kTexelOk && (!only || (*only)[size_t(p)]); };
  std::vector<float> st;
  for (int64_t p = 0; p < s.plane_size(); ++p)
    if (ok(p)) st.push_back(strength[p]);
  st = ConcatOverBands(s, st);
  if (st.empty()) return false;
  std::nth_element(st.begin(), st.begin() + st.size() * 9 / 10, st.end());
  const float clear = 0.1f * st[st.size() * 9 / 10];
  out->assign(shapes.size(), 0.0);
  for (size_t k = 0; k < shapes.size(); ++k) {
    std::vector<float> v;
    for (int64_t p = 0; p < s.plane_size(); ++p)
      if (ok(p) && strength[p] > clear) v.push_back(shapes[k][p]);
    v = ConcatOverBands(s, v);
    if (v.empty()) return false;
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    (*out)[k] = v[v.size() / 2];
  }
  return true;
}

template <typename Lobe>
StatusOr<std::vector<double>> SharedShapeFromMaps(const LightStack& s, const MaterialMaps& m,
                                                  const std::vector<uint8_t>& status) {
  const Image shape = Lobe::LoadShape(m);
  if (shape.empty() || m.specular.empty() || shape.channels() != Lobe::kShapes)
    return InvalidArgument(std::string(Lobe::kModel) + ": maps without per-texel lobe shapes");
  std::vector<const float*> planes;
  for (int k = 0; k < Lobe::kShapes; ++k) planes.push_back(shape.Plane(k).data());
  std::vector<double> out;
  if (!MedianShape(s, status, m.specular.Plane(0).data(), planes, &out))
    return NotFound("no texel shows a specular lobe");
  return out;
}

template <typename Lobe>
StatusOr<FitResult> FitLobe(const LightStack& s, const FitOptions& o, const std::string& name) {
  constexpr int A = Lobe::kAmps, S = Lobe::kShapes, kMax = 5 + A + S;
  auto init = FitLambertRobust(s, o);
  if (!init.ok()) return Status(init.status().code(), name + ": " + init.status().message());
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, Lobe::kModel, name, &r);
  r.status = init->status;
  MaterialMaps& m = r.maps;
  const int n = s.num_images(), C = s.channels(), W = s.width();
  // Per-texel parameter planes while fitting: x (kMax planes).
  Image xs(s.width(), s.height(), kMax);
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<Vec3> dirs(n), halves(n);
  for (int i = 0; i < n; ++i)
    dirs[i] = s.lights()[i].direction, halves[i] = Normalize(dirs[i] + s.view_direction);
  const lobe::LightLanes light_lanes(dirs.data(), halves.data(), n);
  const size_t padded = size_t(light_lanes.padded);
  std::vector<int> iterations(size_t(s.plane_size()), 0);
  // Stage 1's texels: a grid of every k-th column of every k-th row of the whole stack, offset by
  // k/2 from its top-left corner (rows counted from the stack's top, so a band of a distributed
  // stack samples the rows the whole stack would); k = max(1, ⌊√(F / lobe_shape_texels)⌋) for
  // the F texels lambert-robust fitted (the mask's, in effect), so the grid holds about
  // lobe_shape_texels to 2.25 × lobe_shape_texels of them, and every texel when F is below 4 ×
  // lobe_shape_texels.
  const bool estimate_shape = !o.per_texel_lobe && o.lobe_shape.empty();
  int64_t fittable = 0;
  for (int64_t p = 0; p < s.plane_size(); ++p) fittable += r.status[size_t(p)] == kTexelOk;
  SumOverBands(s, &fittable, 1);
  const int grid =
      !estimate_shape || o.lobe_shape_texels == 0
          ? 1
          : std::max(1, int(std::sqrt(double(fittable) / double(o.lobe_shape_texels))));
  // No shape found on the grid: the per-texel fit is kept, so stage 1 runs again on every texel
  // it has not fitted.
  bool rest = false;
  std::vector<char> from_stage1(size_t(s.plane_size()), 0);
  auto in_stage1 = [&](int x, int y) {
    if (rest) return !from_stage1[size_t(int64_t(y) * W + x)];
    return grid <= 1 || (x % grid == grid / 2 && (y + s.band.row0) % grid == grid / 2);
  };
  // lambert-robust's normal and albedo, and the lobe's own start (fitting coordinates).
  auto initial = [&](int64_t p, double* x, int params) {
    const Vec3 n0(init->maps.normal.Plane(0)[p], init->maps.normal.Plane(1)[p],
                  init->maps.normal.Plane(2)[p]);
    const double nz = std::max(n0.z, 0.2);
    x[0] = n0.x / nz, x[1] = n0.y / nz;
    for (int c = 0; c < 3; ++c) x[2 + c] = init->maps.albedo.Plane(C == 1 ? 0 : c)[p];
    double a[A], sh[S];
    Lobe::Init(a, sh);
    for (int k = 0; k < A; ++k) x[5 + k] = a[k];
    for (int k = 0; k < S && 5 + A + k < params; ++k) x[5 + A + k] = sh[k];
  };

  const float clip_level =
      StackMayBeClipped(s) ? kClipLevel : std::numeric_limits<float>::infinity();
  // obs[i · C + c] and, by channel, obs_lanes[c · padded + i] (the padding stays 0, unused).
  auto gather = [&](int64_t p, std::vector<double>& obs, std::vector<double>& obs_lanes,
                    std::vector<char>& use) {
    const Vec3 n0(init->maps.normal.Plane(0)[p], init->maps.normal.Plane(1)[p],
                  init->maps.normal.Plane(2)[p]);
    int used = 0;
    for (int i = 0; i < n; ++i) {
      double lum = 0, pred = 0;
      // A NaN/Inf sample (dead pixel, decode hole) or a clipped one (at the file's maximum
      // code) is dropped.
      bool valid = true;
      for (int c = 0; c < C; ++c) {
        const float raw = s.Sample(i, c, p);
        obs[i * C + c] = double(raw) * inv[i * C + c];
        valid = valid && std::isfinite(obs[i * C + c]) && raw < clip_level;
        lum += obs[i * C + c];
        pred += init->maps.albedo.Plane(C == 1 ? 0 : c)[p] * std::max(0.0, Dot(n0, dirs[i]));
      }
      if (!valid)
        for (int c = 0; c < C; ++c) obs[i * C + c] = 0;
      for (int c = 0; c < C; ++c) obs_lanes[c * padded + size_t(i)] = obs[i * C + c];
      use[i] = valid && !(pred > 0.02 * C && lum < 0.5 * pred);
      used += use[i];
    }
    return used;
  };
  auto stage = [&](auto shared_tag, const std::array<double, S>& shape) {
    constexpr bool kShared = decltype(shared_tag)::value;
    using Problem = lobe::TexelProblem<Lobe, kShared>;
    constexpr int P = Problem::kParams;
    return ForEachTile(s, o, [&](const Tile& t) {
      std::vector<double> obs(size_t(n) * C), obs_lanes(padded * C, 0.0);
      std::vector<char> use(padded, 0);
      Problem prob;
      prob.n = n, prob.channels = C, prob.lights = dirs.data(), prob.obs = obs.data(),
      prob.use = use.data();
      prob.lanes = &light_lanes, prob.obs_lanes = obs_lanes.data();
      prob.halves = halves.data();
      prob.view = s.view_direction;
      prob.shape = shape.data();
      for (int y = t.y0; y < t.y0 + t.height; ++y)
        for (int xx = t.x0; xx < t.x0 + t.width; ++xx) {
          const int64_t p = int64_t(y) * W + xx;
          if (r.status[p] != kTexelOk || (!kShared && !in_stage1(xx, y))) continue;
          // Whether this fit is the texel's result: stage 1 as the shape's estimate leaves a
          // texel it cannot fit (too few usable samples for a free shape, a non-finite solve) to
          // stage 2, which has fewer parameters.
          const bool result = kShared || o.per_texel_lobe || rest;
          const int residuals = gather(p, obs, obs_lanes, use) * C;
          if (residuals < P + 2) {
            if (result) r.status[p] = kTexelTooFewLights;
            continue;
          }
          Eigen::Matrix<double, P, 1> x;
          if (kShared && from_stage1[size_t(p)]) {
            for (int k = 0; k < P; ++k) x[k] = xs.Plane(k)[p];
          } else {
            initial(p, x.data(), P);
          }
          prob.Project(x.data());
          LmOptions lm;
          lm.cauchy_scale = o.robust_scale;
          lm.residuals = residuals;
          // Stage 1 only feeds the median shape when stage 2 follows: a rough solve will do. It
          // keeps clamped steps, whose crawl along a bound stops its 20 iterations short of the
          // box's corners: an early stop the median has relied on. With steps confined to the
          // box, the median exponent over psm gray's 12-light texels went to its bound (2000: a
          // lobe fitting one highlight sample; blinn-phong held-out RMSE 0.0255 → 0.0789,
          // docs/benchmarks.md, session 40).
          if (!kShared && !o.per_texel_lobe) lm.max_iterations = 20, lm.confine_steps = false;
          iterations[p] += SolveTinyLm<P>(prob, &x, lm).iterations;
          if (!x.allFinite()) {
            if (result) r.status[p] = kTexelNonFinite;
            continue;
          }
          for (int k = 0; k < P; ++k) xs.Plane(k)[p] = float(x[k]);
          from_stage1[size_t(p)] = !kShared;
          if (kShared)
            for (int k = 0; k < S; ++k) xs.Plane(5 + A + k)[p] = float(shape[k]);
        }
    });
  };
  bool ok = o.per_texel_lobe || estimate_shape ? stage(std::false_type{}, {}) : true;
  if (ok && !o.per_texel_lobe) {
    std::array<double, S> shape{};
    std::vector<double> median;
    bool have = false;
    if (!o.lobe_shape.empty()) {  // given (a near-light fit's, estimated over every tile)
      if (int(o.lobe_shape.size()) != S)
        return InvalidArgument(name + ": lobe_shape needs " + std::to_string(S) + " values");
      median = o.lobe_shape, have = true;
    } else {
      std::vector<const float*> planes;
      for (int k = 0; k < S; ++k) planes.push_back(xs.Plane(5 + A + k).data());
      have = MedianShape(s, r.status, xs.Plane(5).data(), planes, &median, &from_stage1);
      int64_t fitted = 0;  // the texels the shape was estimated from
      for (char f : from_stage1) fitted += f;
      SumOverBands(s, &fitted, 1);
      r.parameters["lobe_shape_texels"] = double(fitted);
    }
    if (have) std::copy(median.begin(), median.end(), shape.begin());
    if (have) {
      for (int k = 0; k < S; ++k) r.parameters["lobe_shape_" + std::to_string(k)] = shape[k];
      ok = stage(std::true_type{}, shape);
    } else {
      r.warnings.push_back(Warning(WarningCode::kNoSpecularLobe,
                                   "no texel shows a specular lobe; kept the per-texel fit"));
      rest = true, ok = stage(std::false_type{}, {});  // every texel stage 1 has not fitted
    }
  }
  // Fitting coordinates → maps.
  m.specular = Image(s.width(), s.height(), A);
  Image shape_maps(s.width(), s.height(), S);
  for (int64_t p = 0; p < s.plane_size(); ++p) {
    if (r.status[p] != kTexelOk) continue;
    const Vec3 nn = Normalize(Vec3(xs.Plane(0)[p], xs.Plane(1)[p], 1.0));
    for (int c = 0; c < 3; ++c)
      m.normal.Plane(c)[p] = float(nn[c]), m.albedo.Plane(c)[p] = xs.Plane(2 + c)[p];
    for (int k = 0; k < A; ++k) m.specular.Plane(k)[p] = xs.Plane(5 + k)[p];
    for (int k = 0; k < S; ++k) shape_maps.Plane(k)[p] = xs.Plane(5 + A + k)[p];
  }
  Lobe::StoreShape(std::move(shape_maps), &r.parameters, &m);
  double it[2] = {0, 0};  // Σ iterations, texels: integers, exact in any order
  for (size_t p = 0; p < iterations.size(); ++p)
    if (r.status[p] == kTexelOk) it[0] += iterations[p], it[1] += 1;
  SumOverBands(s, it, 2);
  r.parameters["mean_lm_iterations"] = it[1] > 0 ? it[0] / it[1] : 0;
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace

StatusOr<FitResult> FitBlinnPhong(const LightStack& s, const FitOptions& o) {
  return FitLobe<lobe::BlinnPhongLobe>(s, o, "blinn-phong");
}
StatusOr<FitResult> FitCookTorrance(const LightStack& s, const FitOptions& o) {
  return FitLobe<lobe::CookTorranceLobe>(s, o, "cook-torrance");
}
bool HasSharedLobeShape(const std::string& method) {
  return method == "blinn-phong" || method == "cook-torrance" || method == "lafortune1" ||
         method == "lafortune2";
}

StatusOr<std::vector<double>> SharedLobeShape(const std::string& method, const LightStack& s,
                                              const MaterialMaps& m,
                                              const std::vector<uint8_t>& status) {
  if (method == "blinn-phong") return SharedShapeFromMaps<lobe::BlinnPhongLobe>(s, m, status);
  if (method == "cook-torrance") return SharedShapeFromMaps<lobe::CookTorranceLobe>(s, m, status);
  if (method == "lafortune1") return SharedShapeFromMaps<lobe::LafortuneLobes<1>>(s, m, status);
  if (method == "lafortune2") return SharedShapeFromMaps<lobe::LafortuneLobes<2>>(s, m, status);
  return InvalidArgument(method + " has no material-wide lobe shape");
}

StatusOr<FitResult> FitLafortune(const LightStack& s, const FitOptions& o, int lobes) {
  if (lobes == 1) return FitLobe<lobe::LafortuneLobes<1>>(s, o, "lafortune1");
  if (lobes == 2) return FitLobe<lobe::LafortuneLobes<2>>(s, o, "lafortune2");
  return InvalidArgument("lafortune: 1 or 2 lobes, got " + std::to_string(lobes));
}

}  // namespace matfit::fit
