// svbrdf (issue 17): the Cook–Torrance SVBRDF fitted jointly over every view × light of a
// multi-view stack. Per texel, x = (p, q, ρ_r, ρ_g, ρ_b, F0, r) with n = normalize(p, q, 1):
//   p_ic / I_ic = ρ_c max(0, n·l_i) + π D_GGX(n·h_i; r²) G_Smith F_Schlick(v_i·h_i) / (4 n·v_i)
// (core/shading/shading.h, the functions the synthetic BTFs are rendered with), each sample i
// with its own view v_i and half vector h_i = normalize(l_i + v_i). A single view pins F0 and
// the roughness only through the lobe's shape over the lights; across views the Fresnel rise
// and Smith masking toward grazing views separate them, so both are per texel here.
//
// Start: cook-torrance on the most frontal view (lambert-robust, then per-texel LM with the
// material's roughness). Samples left out per texel: non-finite or clipped, seen at a grazing
// angle (n·v < 0.05 at the start) or looking cast-shadowed (below half the start's prediction).
// Solved by the fixed-size Levenberg–Marquardt of tiny_lm.h with the Cauchy loss.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <vector>

#include "core/parallel.h"
#include "core/shading/shading.h"
#include "core/stack_band.h"
#include "fit/fit_common.h"
#include "fit/lobe_problem.h"
#include "fit/methods.h"
#include "fit/tiny_lm.h"

namespace matfit::fit {
namespace {

// Texels gathered together: their samples of every image are read as runs along a row (the
// stack is plane-major), then fitted one by one.
constexpr int kRun = 16;

}  // namespace

StatusOr<FitResult> SvbrdfStart(const LightStack& front, const FitOptions& o) {
  FitOptions fo = o;
  fo.progress = {};
  auto init = FitCookTorrance(front, fo);
  if (!init.ok()) return Status(init.status().code(), "svbrdf: " + init.status().message());
  init->parameters["frontal_view_theta_deg"] = front.view_theta_deg;
  return init;
}

StatusOr<FitResult> FitSvbrdf(const LightStack& s, const FitOptions& o) {
  const std::vector<std::vector<int>> groups = ViewGroups(s);
  const std::vector<int>& frontal = groups[size_t(MostFrontalView(s, groups))];
  // The start: cook-torrance on the most frontal view, its own view as the stack's.
  const LightStack front = SelectView(s, frontal);
  auto start = SvbrdfStart(front, o);
  if (!start.ok()) return start.status();
  return RefineSvbrdf(s, *start, 0, o);
}

StatusOr<FitResult> RefineSvbrdf(const LightStack& s, const FitResult& start, int row0,
                                 const FitOptions& o) {
  const int view_count = int(ViewGroups(s).size());
  const MaterialMaps& im = start.maps;
  if (im.width != s.width() || row0 < 0 || row0 + s.height() > im.height)
    return InvalidArgument("svbrdf: the start's maps do not cover rows " + std::to_string(row0) +
                           ".." + std::to_string(row0 + s.height() - 1) + " of the stack");
  const auto t0 = std::chrono::steady_clock::now();
  using Problem = lobe::TexelProblem<lobe::CookTorranceLobe, false>;
  constexpr int P = Problem::kParams;  // 7
  FitResult r;
  InitResult(s, "cook-torrance", "svbrdf", &r);
  const int64_t off = int64_t(row0) * s.width();  // texel p of s is texel p + off of the start
  for (int64_t p = 0; p < s.plane_size(); ++p)    // the start's verdict inside this stack's mask
    if (r.status[size_t(p)] != kTexelMasked) r.status[size_t(p)] = start.status[size_t(p + off)];
  const int n = s.num_images(), C = s.channels(), W = s.width();
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<Vec3> dirs(static_cast<size_t>(n)), views(dirs.size()), halves(dirs.size());
  for (int i = 0; i < n; ++i) {
    dirs[size_t(i)] = s.lights()[size_t(i)].direction;
    views[size_t(i)] = Normalize(s.ViewOf(i));
    halves[size_t(i)] = Normalize(dirs[size_t(i)] + views[size_t(i)]);
  }
  const lobe::LightLanes light_lanes(dirs.data(), halves.data(), n, views.data());
  const size_t padded = size_t(light_lanes.padded);
  const float clip_level =
      StackMayBeClipped(s) ? kClipLevel : std::numeric_limits<float>::infinity();
  // The start's roughness: the material's when cook-torrance shared one (the default), else the
  // texel's own where it was fitted, else 0.5.
  const auto shared_roughness = start.parameters.find("roughness");
  const bool shared = shared_roughness != start.parameters.end();
  auto start_roughness = [&](int64_t q) {
    if (shared) return shared_roughness->second;
    const float t = im.roughness.empty() ? 0.0f : im.roughness.data()[size_t(q)];
    return t > 0 ? double(t) : 0.5;
  };
  Image xs(s.width(), s.height(), P);
  std::vector<int> iterations(size_t(s.plane_size()), 0), used_samples(size_t(s.plane_size()), 0);

  // Work units are runs of kRun texels along a row (not row strips): a texel costs thousands of
  // samples per LM iteration, so even one row (a band of a streamed fit) must keep every thread
  // busy.
  const int runs_per_row = (W + kRun - 1) / kRun;
  const int64_t runs = int64_t(s.height()) * runs_per_row;
  std::atomic<int64_t> done{0};
  std::atomic<bool> cancelled{false};
  std::mutex progress_mutex;  // the callback is not required to be thread-safe
  ParallelFor(0, runs, [&](int64_t run0, int64_t run1) {
    std::vector<double> obs(size_t(kRun) * n * C);
    std::vector<float> scratch(kRun);
    std::vector<char> use(padded, 0);
    std::vector<double> obs_lanes(padded * C, 0.0);  // the texel's samples by channel
    Problem prob;
    prob.n = n, prob.channels = C, prob.lights = dirs.data(), prob.halves = halves.data();
    prob.views = views.data(), prob.obs = nullptr, prob.use = use.data();
    prob.lanes = &light_lanes, prob.obs_lanes = obs_lanes.data();
    for (int64_t run = run0; run < run1 && !cancelled; ++run) {
      const int64_t d = ++done;  // runs started
      if (o.progress && (d % 64 == 0 || d == runs)) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        if (!o.progress(d, runs)) cancelled = true;
      }
      {
        const int y = int(run / runs_per_row), x0 = int(run % runs_per_row) * kRun;
        const int len = std::min(kRun, W - x0);
        const int64_t p0 = int64_t(y) * W + x0;
        bool any = false;
        for (int k = 0; k < len; ++k) any = any || r.status[size_t(p0 + k)] == kTexelOk;
        if (!any) continue;
        // obs[(k · n + i) · C + c]: texel k's sample of image i, channel c, intensity-normalised.
        for (int i = 0; i < n; ++i)
          for (int c = 0; c < C; ++c) {
            const float* row = s.Texels(i, c, p0, len, scratch.data());
            const float in = inv[size_t(i) * C + c];
            for (int k = 0; k < len; ++k) {
              const float raw = row[k];
              // A clipped sample is marked NaN: dropped below like a non-finite one.
              obs[(size_t(k) * n + i) * C + c] =
                  raw < clip_level ? double(raw) * in : std::numeric_limits<double>::quiet_NaN();
            }
          }
        for (int k = 0; k < len; ++k) {
          const int64_t p = p0 + k;
          if (r.status[size_t(p)] != kTexelOk) continue;
          double* ob = obs.data() + size_t(k) * n * C;
          const int64_t q = p + off;
          const Vec3 n0(im.normal.Plane(0)[q], im.normal.Plane(1)[q], im.normal.Plane(2)[q]);
          const double f0 = im.specular.Plane(0)[q], r0 = start_roughness(q);
          int used = 0;
          for (int i = 0; i < n; ++i) {
            const Vec3& l = dirs[size_t(i)];
            const Vec3& v = views[size_t(i)];
            bool valid = Dot(n0, v) > 0.05;
            double lum = 0, pred = 0;
            const double spec =
                shading::CookTorranceSpecularHalf(f0, r0, n0, l, v, halves[size_t(i)]);
            for (int c = 0; c < C; ++c) {
              double& ov = ob[size_t(i) * C + c];
              valid = valid && std::isfinite(ov);
              lum += ov;
              pred += shading::Lambert(double(im.albedo.Plane(C == 1 ? 0 : c)[q]), n0, l) + spec;
            }
            if (!valid)
              for (int c = 0; c < C; ++c) ob[size_t(i) * C + c] = 0;
            for (int c = 0; c < C; ++c) obs_lanes[c * padded + size_t(i)] = ob[size_t(i) * C + c];
            use[size_t(i)] = valid && !(pred > 0.02 * C && lum < 0.5 * pred);
            used += use[size_t(i)];
          }
          used_samples[size_t(p)] = used;
          if (used * C < P + 2) {
            r.status[size_t(p)] = kTexelTooFewLights;
            continue;
          }
          prob.obs = ob;
          Eigen::Matrix<double, P, 1> x;
          const double nz = std::max(n0.z, 0.2);
          x[0] = n0.x / nz, x[1] = n0.y / nz;
          for (int c = 0; c < 3; ++c) x[2 + c] = im.albedo.Plane(C == 1 ? 0 : c)[q];
          x[5] = f0, x[6] = r0;
          prob.Project(x.data());
          LmOptions lm;
          lm.cauchy_scale = o.robust_scale;
          lm.residuals = used * C;
          iterations[size_t(p)] = SolveTinyLm<P>(prob, &x, lm).iterations;
          if (!x.allFinite()) {
            r.status[size_t(p)] = kTexelNonFinite;
            continue;
          }
          for (int k2 = 0; k2 < P; ++k2) xs.Plane(k2)[p] = float(x[k2]);
        }
      }
    }
  });
  const bool ok = !cancelled;

  MaterialMaps& m = r.maps;
  m.specular = Image(s.width(), s.height(), 1);
  m.roughness = Image(s.width(), s.height(), 1);
  double sums[3] = {0, 0, 0};  // Σ iterations, Σ samples used, texels
  for (int64_t p = 0; p < s.plane_size(); ++p) {
    if (r.status[size_t(p)] != kTexelOk) continue;
    const Vec3 nn = Normalize(Vec3(xs.Plane(0)[p], xs.Plane(1)[p], 1.0));
    for (int c = 0; c < 3; ++c)
      m.normal.Plane(c)[p] = float(nn[c]), m.albedo.Plane(c)[p] = xs.Plane(2 + c)[p];
    m.specular.Plane(0)[p] = xs.Plane(5)[p];
    m.roughness.Plane(0)[p] = xs.Plane(6)[p];
    sums[0] += iterations[size_t(p)], sums[1] += used_samples[size_t(p)], sums[2] += 1;
  }
  SumOverBands(s, sums, 3);
  r.parameters["views"] = double(view_count);
  r.parameters["frontal_view_theta_deg"] = start.parameters.count("frontal_view_theta_deg")
                                               ? start.parameters.at("frontal_view_theta_deg")
                                               : 0.0;
  if (shared) r.parameters["start_roughness"] = shared_roughness->second;
  r.parameters["mean_lm_iterations"] = sums[2] > 0 ? sums[0] / sums[2] : 0;
  r.parameters["mean_samples_used"] = sums[2] > 0 ? sums[1] / sums[2] : 0;
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
