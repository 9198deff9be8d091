#include "fit/score.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <limits>
#include <map>
#include <mutex>

#include "core/model/model.h"
#include "core/parallel.h"
#include "core/simd_clones.h"
#include "fit/fit_common.h"
#include "fit/fit_types.h"

namespace matfit::fit {
namespace {

// Σ_t [ok_t] (obs_t − I · pred_t)² over a run: the difference in float (8 lanes; its rounding
// is relative to each sample), its square summed in double in two 4-lane accumulators (the
// compiler will not reassociate a scalar double sum), reduced in a fixed order so the result
// does not depend on the ISA clone. `ok` holds 1.0f for texels to score, 0 elsewhere: a
// select, so NaN outside scored texels never enters the sum.
typedef double V4d __attribute__((vector_size(32)));
typedef float V4f __attribute__((vector_size(16)));
typedef float V8f __attribute__((vector_size(32)));

// 8 differences squared into two double accumulators.
__attribute__((always_inline)) inline void Accumulate8(const float* obs, const float* pred,
                                                       float intensity, const float* ok, V4d* a,
                                                       V4d* b) {
  V8f o, p, w;
  std::memcpy(&o, obs, sizeof o), std::memcpy(&p, pred, sizeof p), std::memcpy(&w, ok, sizeof w);
  const V8f d = w != 0 ? o - intensity * p : V8f{};
  const V4d lo = __builtin_convertvector(V4f{d[0], d[1], d[2], d[3]}, V4d);
  const V4d hi = __builtin_convertvector(V4f{d[4], d[5], d[6], d[7]}, V4d);
  *a += lo * lo, *b += hi * hi;
}

MATFIT_CLONES_V3
double SumSquaredDiff(const float* obs, const float* pred, float intensity, const float* ok,
                      int n) {
  V4d a = {}, b = {}, c = {}, e = {};  // four chains: the adds' latency, not the loads, bound it
  int t = 0;
  for (; t + 16 <= n; t += 16) {
    Accumulate8(obs + t, pred + t, intensity, ok + t, &a, &b);
    Accumulate8(obs + t + 8, pred + t + 8, intensity, ok + t + 8, &c, &e);
  }
  double tail = 0;
  for (; t < n; ++t) {
    const double d = ok[t] != 0 ? double(obs[t] - intensity * pred[t]) : 0.0;
    tail += d * d;
  }
  const V4d s = (a + c) + (b + e);
  return ((s[0] + s[2]) + (s[1] + s[3])) + tail;
}

// One light and channel of a run: q = raw / I, r = q − pred for the samples that are finite and
// below the clip level; Σ r², Σ |q|, the sample count, and whether the light was used. Four
// texels at a time in double, the same operations as one at a time (so the same sums): valid
// ⇔ −∞ < raw < clip and |r| < ∞ (NaN fails every comparison).
typedef long long V4l __attribute__((vector_size(32)));
typedef int V4i __attribute__((vector_size(16)));

MATFIT_CLONES_V3
void ResidualSums(const float* __restrict raw, const float* __restrict pred, float inv,
                  float clip_level, int n, double* __restrict acc, double* __restrict sum,
                  int* __restrict k, int* __restrict used) {
  const double inf = std::numeric_limits<double>::infinity(), clip = clip_level, scale = inv;
  int t = 0;
  for (; t + 4 <= n; t += 4) {
    V4f rf, pf;
    V4d a, b;
    V4i kt, ut;
    std::memcpy(&rf, raw + t, sizeof rf), std::memcpy(&pf, pred + t, sizeof pf);
    std::memcpy(&a, acc + t, sizeof a), std::memcpy(&b, sum + t, sizeof b);
    std::memcpy(&kt, k + t, sizeof kt), std::memcpy(&ut, used + t, sizeof ut);
    const V4d rd = __builtin_convertvector(rf, V4d), q = rd * scale;
    const V4d r = q - __builtin_convertvector(pf, V4d);
    const V4d ar = r < 0 ? -r : r, aq = q < 0 ? -q : q;
    const V4l valid = (rd > -inf) & (rd < clip) & (ar < inf);
    a += valid ? r * r : V4d{}, b += valid ? aq : V4d{};
    const V4i v = __builtin_convertvector(valid, V4i);  // −1 or 0
    kt -= v, ut |= v & 1;
    std::memcpy(acc + t, &a, sizeof a), std::memcpy(sum + t, &b, sizeof b);
    std::memcpy(k + t, &kt, sizeof kt), std::memcpy(used + t, &ut, sizeof ut);
  }
  for (; t < n; ++t) {
    const double q = double(raw[t]) * scale;
    const double r = q - double(pred[t]);
    const bool valid = std::isfinite(raw[t]) && raw[t] < clip_level && std::isfinite(r);
    acc[t] += valid ? r * r : 0.0;
    sum[t] += valid ? std::abs(q) : 0.0;
    k[t] += valid;
    used[t] |= valid;
  }
}

ReconstructionMetrics ReduceReconstruction(const LightStack& s, const std::vector<int>& images,
                                           const std::vector<double>& run_sum,
                                           const std::vector<int64_t>& run_count, int64_t runs) {
  const int n = int(images.size());
  ReconstructionMetrics m;
  std::map<int, std::pair<double, int64_t>> groups;
  double total = 0;
  for (int i = 0; i < n; ++i) {
    double sum = 0;
    int64_t count = 0;
    for (int64_t r = 0; r < runs; ++r)
      sum += run_sum[size_t(r * n + i)], count += run_count[size_t(r * n + i)];
    total += sum;
    m.samples += count;
    auto& g = groups[int(std::lround(s.lights()[size_t(images[size_t(i)])].theta_deg / 15.0)) * 15];
    g.first += sum, g.second += count;
  }
  const double mse = m.samples ? total / m.samples : 0;
  m.deviation_percent = 100 * mse;
  m.rmse = std::sqrt(mse);
  m.psnr_db = mse > 0 ? 10 * std::log10(1.0 / mse) : INFINITY;
  for (auto& [t, g] : groups)
    m.deviation_percent_by_theta[t] = g.second ? 100 * g.first / g.second : 0;
  return m;
}

}  // namespace

StackScore ScoreStack(const LightStack& s, const std::vector<int>& images, const MaterialMaps& maps,
                      const std::vector<uint8_t>& status, const ProgressFn& progress,
                      ScoreParts parts) {
  const int64_t T = s.plane_size();
  const int n = int(images.size()), C = s.channels();
  const bool reconstruction = parts.reconstruction, residuals = parts.residuals;
  const int64_t runs = (T + kEvalRun - 1) / kEvalRun;
  StackScore out;
  TexelResiduals& res = out.residuals;
  if (residuals) {
    res.rss.assign(size_t(T), 0.0), res.level.assign(size_t(T), 0.0);
    res.samples.assign(size_t(T), 0), res.used_lights.assign(size_t(T), 0);
  }
  std::vector<Vec3f> dirs;
  for (int i : images) dirs.emplace_back(s.lights()[size_t(i)].direction);
  const BatchEvaluator eval(maps, dirs, Vec3f(s.view_direction));
  const std::vector<float> inv = InverseIntensities(s);
  const float clip_level =
      StackMayBeClipped(s) ? kClipLevel : std::numeric_limits<float>::infinity();
  // Reconstruction: Σ d² and the sample count per run and light, reduced in run order.
  std::vector<double> run_sum(reconstruction ? size_t(runs * n) : 0, 0.0);
  std::vector<int64_t> run_count(reconstruction ? size_t(runs * n) : 0, 0);
  std::atomic<int64_t> done{0};
  std::mutex progress_mutex;
  ParallelFor(
      0, runs,
      [&](int64_t r0, int64_t r1) {
        std::vector<float> pred(size_t(eval.group()) * 3 * kEvalRun), scratch(kEvalRun);
        std::vector<double> acc(kEvalRun), sum(kEvalRun);
        std::vector<int> k(kEvalRun), m(kEvalRun), used(kEvalRun);
        float ok[kEvalRun];
        for (int64_t r = r0; r < r1; ++r) {
          const int64_t p0 = r * kEvalRun;
          const int len = int(std::min<int64_t>(kEvalRun, T - p0));
          int ok_count = 0;
          for (int t = 0; t < len; ++t) {
            const bool use = status.empty() || status[size_t(p0 + t)] == kTexelOk;
            ok[t] = use ? 1.0f : 0.0f, ok_count += use;
          }
          if (ok_count == 0) continue;
          if (residuals) {
            std::fill_n(acc.begin(), len, 0.0), std::fill_n(sum.begin(), len, 0.0);
            std::fill_n(k.begin(), len, 0), std::fill_n(m.begin(), len, 0);
          }
          for (int j = 0; j < n; ++j) {
            const int i = images[size_t(j)];
            const int in_group = j % eval.group();  // predictions come a group of lights at once
            if (in_group == 0)
              eval.EvaluateLights(j, std::min(eval.group(), n - j), p0, len, C, pred.data());
            if (residuals) std::fill_n(used.begin(), len, 0);
            double d2 = 0;
            for (int c = 0; c < C; ++c) {
              const float* raw = s.Texels(i, c, p0, len, scratch.data());
              const float* pc = pred.data() + (size_t(in_group) * C + c) * len;
              if (residuals)
                ResidualSums(raw, pc, inv[size_t(i) * C + c], clip_level, len, acc.data(),
                             sum.data(), k.data(), used.data());
              if (reconstruction)
                d2 += SumSquaredDiff(
                    raw, pc, float(s.lights()[size_t(i)].intensity[C == 1 ? 0 : c]), ok, len);
            }
            if (residuals)
              for (int t = 0; t < len; ++t) m[size_t(t)] += used[size_t(t)];
            if (reconstruction) {
              run_sum[size_t(r * n + j)] = d2;
              run_count[size_t(r * n + j)] = int64_t(ok_count) * C;
            }
          }
          for (int t = 0; t < len && residuals; ++t) {
            if (ok[t] == 0) continue;
            const size_t p = size_t(p0 + t);
            res.rss[p] = acc[size_t(t)], res.samples[p] = k[size_t(t)];
            res.used_lights[p] = m[size_t(t)];
            res.level[p] = k[size_t(t)] ? sum[size_t(t)] / k[size_t(t)] : 0;
          }
        }
        const int64_t d = done += r1 - r0;
        if (progress) {
          std::lock_guard<std::mutex> lock(progress_mutex);
          progress(d, runs);
        }
      },
      4);
  if (reconstruction)
    out.reconstruction = ReduceReconstruction(s, images, run_sum, run_count, runs);
  return out;
}

StackScore ScoreStack(const LightStack& s, const MaterialMaps& maps,
                      const std::vector<uint8_t>& status, const ProgressFn& progress,
                      ScoreParts parts) {
  std::vector<int> all(static_cast<size_t>(s.num_images()));
  for (int i = 0; i < s.num_images(); ++i) all[size_t(i)] = i;
  return ScoreStack(s, all, maps, status, progress, parts);
}

}  // namespace matfit::fit
