#include "fit/score.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <map>
#include <memory>
#include <mutex>

#include "core/color.h"
#include "core/model/model.h"
#include "core/near_lights.h"
#include "core/parallel.h"
#include "core/simd_clones.h"
#include "core/stack_band.h"
#include "fit/fit_common.h"
#include "fit/fit_types.h"

namespace matfit::fit {
namespace {

typedef double V8d __attribute__((vector_size(64)));
typedef float V8f __attribute__((vector_size(32)));
typedef int V8i __attribute__((vector_size(32)));
typedef int64_t V8l __attribute__((vector_size(64)));

// |v| by clearing the sign bits: a compare of 64-byte vectors is lowered to scalar code in the
// AVX2 clone of a target_clones function (GCC 12).
inline V8d Abs(V8d v) { return (V8d)((V8l)v & (V8l{} + INT64_MAX)); }

constexpr int kMaxChannels = 3;  // stacks hold 1 or 3 channels

// One light's channels (raw samples, predictions, 1 / I and I per channel) over a run.
struct LightChannels {
  const float* raw[kMaxChannels];
  const float* pred[kMaxChannels];
  float inv[kMaxChannels], intensity[kMaxChannels];
};

// Both scores of one light in one sweep of its samples, eight texels at a time:
// - residuals (per texel t, over the lights): q = raw / I, r = q − pred for the samples that are
//   finite and below the clip level with a finite prediction, and for the clipped ones (finite,
//   at or above the clip level) that the prediction undershoots, float(raw · (1 / I)) > pred: a
//   clipped sample records only that the value reached the clip, so in the recorded range its
//   error is max(0, q − pred), counted where it is positive (docs/stability.md); Σ r² (acc),
//   Σ |q| (sum), the sample count (k), the lights with at least one unclipped such sample (m) and
//   the lights with a clipped sample (sat). q and r in double, each texel's sums in light then
//   channel order: the same as one sample at a time. The tests run on the floats (finite raw,
//   pred and 1 / I make q, r finite in double: |q| < 2^256), and a sample not counted enters as
//   raw = pred = 0, adding +0.
// - reconstruction: Σ_t,c [ok_t] (raw − I · pred)², the difference in float (its rounding is
//   relative to each sample) squared and summed in double in eight-lane chains reduced in a
//   fixed order, so the sum does not depend on the ISA clone or the thread count. `ok` is 1.0f for
//   texels to score, 0 elsewhere: a select, so NaN outside scored texels never enters the sum.
template <int C, bool kResiduals, bool kReconstruction, bool kClipped>
MATFIT_CLONES_V4 double ScoreLight(const LightChannels& l, float clip_level, const float* ok, int n,
                                   double* __restrict acc, double* __restrict sum,
                                   int* __restrict k, int* __restrict m, int* __restrict sat) {
  const float inf = std::numeric_limits<float>::infinity();
  V8d rec = {};
  // 1 / I = ∞ (I = 0) makes every q of the channel non-finite: none is valid, and its scale is 0
  // so that the invalid samples still add +0.
  V8i channel_ok[kMaxChannels];
  double scale[kMaxChannels];
  bool finite[kMaxChannels];
  for (int c = 0; c < C; ++c) {
    finite[c] = std::abs(l.inv[c]) < inf;
    channel_ok[c] = V8i{} - int(finite[c]), scale[c] = finite[c] ? double(l.inv[c]) : 0.0;
  }
  int t = 0;
  for (; t + 8 <= n; t += 8) {
    V8d a, b;
    V8i kt, mt, st = {}, used = {}, clipped = {};
    V8f w;
    if constexpr (kResiduals) {
      std::memcpy(&a, acc + t, sizeof a), std::memcpy(&b, sum + t, sizeof b);
      std::memcpy(&kt, k + t, sizeof kt), std::memcpy(&mt, m + t, sizeof mt);
      if constexpr (kClipped) std::memcpy(&st, sat + t, sizeof st);
    }
    if constexpr (kReconstruction) std::memcpy(&w, ok + t, sizeof w);
    for (int c = 0; c < C; ++c) {
      V8f rf, pf;
      std::memcpy(&rf, l.raw[c] + t, sizeof rf), std::memcpy(&pf, l.pred[c] + t, sizeof pf);
      if constexpr (kResiduals) {
        const V8f ap = pf < 0 ? -pf : pf;
        const V8i fine = (rf > -inf) & (rf < inf) & (ap < inf) & channel_ok[c];  // −1, 0
        // A stack that cannot clip (clip level +∞) has no clipped sample: one mask.
        const V8i valid = kClipped ? fine & (rf < clip_level) : fine;
        const V8i clip = kClipped ? fine & (rf >= clip_level) : V8i{};
        const V8i use = kClipped ? valid | (clip & (rf * l.inv[c] > pf)) : valid;
        const V8d q = __builtin_convertvector(use ? rf : V8f{}, V8d) * scale[c];
        const V8d r = q - __builtin_convertvector(use ? pf : V8f{}, V8d);
        a += r * r, b += Abs(q);
        kt -= use, used |= valid & 1;
        if constexpr (kClipped) clipped |= clip & 1;
      }
      if constexpr (kReconstruction) {
        const V8f d = w != 0 ? rf - l.intensity[c] * pf : V8f{};
        const V8d dd = __builtin_convertvector(d, V8d);
        rec += dd * dd;
      }
    }
    if constexpr (kResiduals) {
      mt += used;
      if constexpr (kClipped) st += clipped;
      std::memcpy(acc + t, &a, sizeof a), std::memcpy(sum + t, &b, sizeof b);
      std::memcpy(k + t, &kt, sizeof kt), std::memcpy(m + t, &mt, sizeof mt);
      if constexpr (kClipped) std::memcpy(sat + t, &st, sizeof st);
    }
  }
  double tail = 0;
  for (; t < n; ++t) {
    int used = 0, clipped = 0;
    for (int c = 0; c < C; ++c) {
      const float raw = l.raw[c][t], pred = l.pred[c][t];
      if constexpr (kResiduals) {
        const bool fine = raw > -inf && raw < inf && std::abs(pred) < inf && finite[c];
        const bool valid = fine && raw < clip_level, clip = fine && raw >= clip_level;
        const bool use = valid || (clip && raw * l.inv[c] > pred);
        const double q = double(use ? raw : 0.0f) * scale[c];
        const double r = q - double(use ? pred : 0.0f);
        acc[t] += r * r, sum[t] += std::abs(q);
        k[t] += use, used |= valid, clipped |= clip;
      }
      if constexpr (kReconstruction) {
        const double d = ok[t] != 0 ? double(raw - l.intensity[c] * pred) : 0.0;
        tail += d * d;
      }
    }
    if constexpr (kResiduals) m[t] += used, sat[t] += clipped;
  }
  const double r4[4] = {rec[0] + rec[4], rec[1] + rec[5], rec[2] + rec[6], rec[3] + rec[7]};
  return ((r4[0] + r4[2]) + (r4[1] + r4[3])) + tail;
}

// The instance for the channel count and the parts asked for.
template <int C>
double ScoreLightParts(bool residuals, bool reconstruction, const LightChannels& l,
                       float clip_level, const float* ok, int n, double* acc, double* sum, int* k,
                       int* m, int* sat) {
  const bool clipped = clip_level < std::numeric_limits<float>::infinity();
  if (residuals && reconstruction)
    return clipped ? ScoreLight<C, true, true, true>(l, clip_level, ok, n, acc, sum, k, m, sat)
                   : ScoreLight<C, true, true, false>(l, clip_level, ok, n, acc, sum, k, m, sat);
  if (residuals)
    return clipped ? ScoreLight<C, true, false, true>(l, clip_level, ok, n, acc, sum, k, m, sat)
                   : ScoreLight<C, true, false, false>(l, clip_level, ok, n, acc, sum, k, m, sat);
  return ScoreLight<C, false, true, false>(l, clip_level, ok, n, acc, sum, k, m, sat);
}

// The 8-bit sRGB code of every stored code of an integer stack: LinearToSrgb8Batch of its
// linear value, the same byte the float path computes from the decoded sample (for an 8-bit sRGB
// stack, the code itself). Empty for float stacks.
std::vector<uint8_t> Srgb8OfCodes(const LightStack& s) {
  std::vector<uint8_t> out(s.lut().size());
  if (!out.empty()) LinearToSrgb8Batch(s.lut().data(), 1.0f, int(out.size()), out.data());
  return out;
}

// Σ over scored texels and channels of (code(raw) − code(I · pred))², codes by LinearToSrgb8Fast:
// an integer, so the sum is exact in any order. Raw samples of an integer stack take their code
// from `srgb8_of_code` (Srgb8OfCodes) by their stored code: no float conversion per sample.
// Texels scored: ok[t] ≠ 0 into *sum; with `ok_common`, ok_common[t] ≠ 0 into *sum_common too.
void Srgb8SquaredError(const LightStack& s, int image, int64_t p0,
                       const std::vector<uint8_t>& srgb8_of_code, const LightChannels& l,
                       int channels, const float* ok, const float* ok_common, int n, int64_t* sum,
                       int64_t* sum_common) {
  constexpr int kBlock = 256;
  uint8_t a[kBlock], b[kBlock];
  *sum = 0;
  if (ok_common) *sum_common = 0;
  for (int c = 0; c < channels; ++c) {
    const uint8_t* u8 =
        s.sample_type() == SampleType::kUint8 ? s.Codes<uint8_t>(image, c).data() + p0 : nullptr;
    const uint16_t* u16 =
        s.sample_type() == SampleType::kUint16 ? s.Codes<uint16_t>(image, c).data() + p0 : nullptr;
    for (int t0 = 0; t0 < n; t0 += kBlock) {
      const int m = std::min(kBlock, n - t0);
      if (u8)
        for (int t = 0; t < m; ++t) a[t] = srgb8_of_code[u8[t0 + t]];
      else if (u16)
        for (int t = 0; t < m; ++t) a[t] = srgb8_of_code[u16[t0 + t]];
      else
        LinearToSrgb8Batch(l.raw[c] + t0, 1.0f, m, a);
      LinearToSrgb8Batch(l.pred[c] + t0, l.intensity[c], m, b);
      int32_t block = 0, block_common = 0;  // ≤ 256 · 255² < 2^31
      for (int t = 0; t < m; ++t) {
        const int d = int(a[t]) - int(b[t]);
        block += ok[t0 + t] != 0 ? d * d : 0;
        if (ok_common) block_common += ok_common[t0 + t] != 0 ? d * d : 0;
      }
      *sum += block;
      if (ok_common) *sum_common += block_common;
    }
  }
}

ReconstructionMetrics ReduceReconstruction(const LightStack& s, const std::vector<int>& images,
                                           const std::vector<double>& run_sum,
                                           const std::vector<int64_t>& run_count,
                                           const std::vector<int64_t>& run_srgb8, int64_t runs) {
  const int n = int(images.size());
  ReconstructionMetrics m;
  std::map<int, std::pair<double, int64_t>> groups;
  double total = 0;
  int64_t total8 = 0;
  for (int64_t v : run_srgb8) total8 += v;
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
  if (!run_srgb8.empty() && m.samples) {
    const double mse8 = double(total8) / double(m.samples);
    m.rmse_srgb8 = std::sqrt(mse8);
    m.psnr_srgb8_db = mse8 > 0 ? 10 * std::log10(255.0 * 255.0 / mse8) : INFINITY;
  }
  return m;
}

// Near lights: texels [p0, p0 + len) as indices and positions, for NearLightEvaluator.
struct NearRun {
  std::vector<int64_t> texels = std::vector<int64_t>(kEvalRun);
  std::vector<Vec3> points = std::vector<Vec3>(kEvalRun);
  void Set(const LightStack& s, int64_t p0, int len) {
    for (int t = 0; t < len; ++t) {
      const int64_t p = p0 + t;
      texels[size_t(t)] = p;
      points[size_t(t)] = NearTexelPosition(s, double(p % s.width()), double(p / s.width()));
    }
  }
};

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
    res.clipped_lights.assign(size_t(T), 0);
  }
  std::vector<Vec3f> dirs, views;  // each image's own view (multi-view stacks)
  for (int i : images) dirs.emplace_back(s.lights()[size_t(i)].direction);
  for (int i : images) views.emplace_back(s.ViewOf(i));
  const BatchEvaluator eval(maps, dirs, views);
  const bool near = s.has_light_positions();
  const std::vector<float> inv = InverseIntensities(s);
  const float clip_level =
      StackMayBeClipped(s) ? kClipLevel : std::numeric_limits<float>::infinity();
  // Reconstruction: Σ d² and the sample count per run and light, reduced in run order.
  std::vector<double> run_sum(reconstruction ? size_t(runs * n) : 0, 0.0);
  std::vector<int64_t> run_count(reconstruction ? size_t(runs * n) : 0, 0);
  const bool srgb8 = reconstruction && parts.srgb8;
  std::vector<int64_t> run_srgb8(srgb8 ? size_t(runs * n) : 0, 0);
  // The same three over the common texel set (parts.common).
  const bool common = reconstruction && parts.common;
  std::vector<double> run_sum_c(common ? run_sum.size() : 0, 0.0);
  std::vector<int64_t> run_count_c(common ? run_count.size() : 0, 0);
  std::vector<int64_t> run_srgb8_c(common ? run_srgb8.size() : 0, 0);
  const std::vector<uint8_t> srgb8_of_code = srgb8 ? Srgb8OfCodes(s) : std::vector<uint8_t>{};
  std::atomic<int64_t> done{0};
  std::mutex progress_mutex;
  ParallelFor(
      0, runs,
      [&](int64_t r0, int64_t r1) {
        std::vector<float> pred(size_t(eval.group()) * 3 * kEvalRun),
            scratch(size_t(kMaxChannels) * kEvalRun);
        std::vector<double> acc(kEvalRun), sum(kEvalRun);
        std::vector<int> k(kEvalRun), m(kEvalRun), sat(kEvalRun);
        std::unique_ptr<NearRun> near_run(near ? new NearRun : nullptr);
        std::unique_ptr<NearLightEvaluator> near_eval(
            near ? new NearLightEvaluator(maps, Vec3f(s.view_direction)) : nullptr);
        float ok[kEvalRun], ok_common[kEvalRun];
        for (int64_t r = r0; r < r1; ++r) {
          const int64_t p0 = r * kEvalRun;
          const int len = int(std::min<int64_t>(kEvalRun, T - p0));
          int ok_count = 0, common_count = 0;
          for (int t = 0; t < len; ++t) {
            const uint8_t st = status.empty() ? uint8_t(kTexelOk) : status[size_t(p0 + t)];
            ok[t] = st == kTexelOk ? 1.0f : 0.0f, ok_count += st == kTexelOk;
            ok_common[t] = st != kTexelMasked ? 1.0f : 0.0f, common_count += st != kTexelMasked;
          }
          if (ok_count == 0 && (!common || common_count == 0)) continue;
          if (residuals) {
            std::fill_n(acc.begin(), len, 0.0), std::fill_n(sum.begin(), len, 0.0);
            std::fill_n(k.begin(), len, 0), std::fill_n(m.begin(), len, 0);
            std::fill_n(sat.begin(), len, 0);
          }
          if (near) near_run->Set(s, p0, len);
          for (int j = 0; j < n; ++j) {
            const int i = images[size_t(j)];
            // Predictions come a group of lights at once (near lights: one, texel by texel).
            const int in_group = near ? 0 : j % eval.group();
            if (near)
              near_eval->Evaluate(s.lights()[size_t(i)], near_run->texels.data(),
                                  near_run->points.data(), len, pred.data());
            else if (in_group == 0)
              eval.EvaluateLights(j, std::min(eval.group(), n - j), p0, len, C, pred.data());
            LightChannels l;
            for (int c = 0; c < C; ++c) {
              l.raw[c] = s.Texels(i, c, p0, len, scratch.data() + size_t(c) * kEvalRun);
              l.pred[c] = pred.data() + (size_t(in_group) * C + c) * len;
              l.inv[c] = inv[size_t(i) * C + c];
              l.intensity[c] = float(s.lights()[size_t(i)].intensity[C == 1 ? 0 : c]);
            }
            const double d2 =
                C == 1 ? ScoreLightParts<1>(residuals, reconstruction, l, clip_level, ok, len,
                                            acc.data(), sum.data(), k.data(), m.data(), sat.data())
                       : ScoreLightParts<3>(residuals, reconstruction, l, clip_level, ok, len,
                                            acc.data(), sum.data(), k.data(), m.data(), sat.data());
            const size_t at = size_t(r * n + j);
            if (reconstruction) run_sum[at] = d2, run_count[at] = int64_t(ok_count) * C;
            if (common) {
              // The reconstruction part alone with the common weights: the pass a common status
              // would make.
              run_sum_c[at] = C == 1
                                  ? ScoreLightParts<1>(false, true, l, clip_level, ok_common, len,
                                                       nullptr, nullptr, nullptr, nullptr, nullptr)
                                  : ScoreLightParts<3>(false, true, l, clip_level, ok_common, len,
                                                       nullptr, nullptr, nullptr, nullptr, nullptr);
              run_count_c[at] = int64_t(common_count) * C;
            }
            if (srgb8)
              Srgb8SquaredError(s, i, p0, srgb8_of_code, l, C, ok, common ? ok_common : nullptr,
                                len, &run_srgb8[at], common ? &run_srgb8_c[at] : nullptr);
          }
          for (int t = 0; t < len && residuals; ++t) {
            if (ok[t] == 0) continue;
            const size_t p = size_t(p0 + t);
            res.rss[p] = acc[size_t(t)], res.samples[p] = k[size_t(t)];
            res.used_lights[p] = m[size_t(t)], res.clipped_lights[p] = sat[size_t(t)];
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
  if (reconstruction) {
    int64_t all_runs = runs;
    if (s.is_band()) {
      // Every band's runs after the ones above it: with bands that start on a run boundary
      // (fit/fit_job.cc), the same runs and the same sums as the whole stack's.
      run_sum = ConcatOverBands(s, run_sum), run_count = ConcatOverBands(s, run_count);
      if (srgb8) run_srgb8 = ConcatOverBands(s, run_srgb8);
      if (common) {
        run_sum_c = ConcatOverBands(s, run_sum_c), run_count_c = ConcatOverBands(s, run_count_c);
        if (srgb8) run_srgb8_c = ConcatOverBands(s, run_srgb8_c);
      }
      all_runs = n > 0 ? int64_t(run_sum.size()) / n : 0;
    }
    out.reconstruction = ReduceReconstruction(s, images, run_sum, run_count, run_srgb8, all_runs);
    if (common)
      out.reconstruction_common =
          ReduceReconstruction(s, images, run_sum_c, run_count_c, run_srgb8_c, all_runs);
  }
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
