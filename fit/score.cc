#include "fit/score.h"

#include <algorithm>
#include <atomic>
#include <limits>
#include <mutex>

#include "core/model/model.h"
#include "core/parallel.h"
#include "fit/fit_common.h"
#include "fit/fit_types.h"
#include "fit/residual_kernels.h"

namespace matfit::fit {

StackScore ScoreStack(const LightStack& s, const MaterialMaps& maps,
                      const std::vector<uint8_t>& status, const ProgressFn& progress,
                      bool reconstruction) {
  const int64_t T = s.plane_size();
  const int n = s.num_images(), C = s.channels();
  const int64_t runs = (T + kEvalRun - 1) / kEvalRun;
  StackScore out;
  TexelResiduals& res = out.residuals;
  res.rss.assign(size_t(T), 0.0), res.level.assign(size_t(T), 0.0);
  res.samples.assign(size_t(T), 0), res.used_lights.assign(size_t(T), 0);
  std::vector<Vec3f> dirs;
  for (const auto& l : s.lights()) dirs.emplace_back(l.direction);
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
        std::vector<float> pred(size_t(3) * kEvalRun), scratch(kEvalRun);
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
          std::fill_n(acc.begin(), len, 0.0), std::fill_n(sum.begin(), len, 0.0);
          std::fill_n(k.begin(), len, 0), std::fill_n(m.begin(), len, 0);
          for (int i = 0; i < n; ++i) {
            eval.Evaluate(i, p0, len, C, pred.data());
            std::fill_n(used.begin(), len, 0);
            double d2 = 0;
            for (int c = 0; c < C; ++c) {
              const float* raw = s.Texels(i, c, p0, len, scratch.data());
              const float* pc = pred.data() + size_t(c) * len;
              ResidualSums(raw, pc, inv[size_t(i) * C + c], clip_level, len, acc.data(), sum.data(),
                           k.data(), used.data());
              if (reconstruction)
                d2 += SumSquaredDiff(
                    raw, pc, float(s.lights()[size_t(i)].intensity[C == 1 ? 0 : c]), ok, len);
            }
            for (int t = 0; t < len; ++t) m[size_t(t)] += used[size_t(t)];
            if (reconstruction) {
              run_sum[size_t(r * n + i)] = d2;
              run_count[size_t(r * n + i)] = int64_t(ok_count) * C;
            }
          }
          for (int t = 0; t < len; ++t) {
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
  if (reconstruction) {
    std::vector<int> all(static_cast<size_t>(n));
    for (int i = 0; i < n; ++i) all[size_t(i)] = i;
    out.reconstruction = ReduceReconstruction(s, all, run_sum, run_count, runs);
  }
  return out;
}

}  // namespace matfit::fit
