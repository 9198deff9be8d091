#include "fit/valid_refit.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <vector>

#include "core/light_stack.h"
#include "core/parallel.h"
#include "fit/fit_common.h"

namespace matfit::fit {

namespace {

bool NeedsRefit(uint8_t status) { return status == kTexelSaturated || status == kTexelNonFinite; }

}  // namespace

void RefitFromValidSamples(const LightStack& s, const RefitOptions& options, const SubsetFit& fit,
                           FitResult* r) {
  const int W = s.width(), H = s.height(), n = s.num_images(), C = s.channels();
  std::vector<int> rows;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (NeedsRefit(r->status[int64_t(y) * W + x])) {
        rows.push_back(y);
        break;
      }
  if (rows.empty()) return;
  r->dropped_lights.assign(size_t(s.plane_size()), 0);
  const std::vector<float> inv = InverseIntensities(s);
  const float clip_level = options.drop_clipped && StackMayBeClipped(s)
                               ? kClipLevel
                               : std::numeric_limits<float>::infinity();
  std::atomic<int64_t> refit{0}, dropped{0};
  ParallelFor(0, int64_t(rows.size()), [&](int64_t b, int64_t e) {
    std::vector<int> xs;
    std::vector<double> obs;  // [texel][i · C + c]
    std::vector<uint8_t> valid;
    std::vector<float> scratch(s.is_float() ? 0 : W);
    int64_t local_refit = 0, local_dropped = 0;
    for (int64_t q = b; q < e; ++q) {
      const int y = rows[size_t(q)];
      xs.clear();
      for (int x = 0; x < W; ++x)
        if (NeedsRefit(r->status[int64_t(y) * W + x])) xs.push_back(x);
      const size_t m = xs.size(), stride = size_t(n) * C;
      obs.assign(m * stride, 0.0);
      valid.assign(m * n, 1);
      for (int i = 0; i < n; ++i)
        for (int c = 0; c < C; ++c) {
          const float* src = s.Row(i, c, y, 0, W, scratch.data());
          for (size_t k = 0; k < m; ++k) {
            const float v = src[xs[k]];
            const bool ok = std::isfinite(v) && v < clip_level;
            valid[k * n + i] &= uint8_t(ok);
            obs[k * stride + size_t(i) * C + c] = double(v) * inv[i * C + c];
          }
        }
      for (size_t k = 0; k < m; ++k) {
        const int64_t p = int64_t(y) * W + xs[k];
        double* o = obs.data() + k * stride;
        const uint8_t* v = valid.data() + k * n;
        int count = 0;
        for (int i = 0; i < n; ++i) {
          count += v[i];
          if (!v[i])
            for (int c = 0; c < C; ++c) o[i * C + c] = 0;  // 1 / I · NaN must not leak
        }
        TexelSamples t;
        t.p = p, t.n = n, t.channels = C, t.obs = o, t.valid = v, t.valid_count = count;
        const uint8_t status = fit(t, r);
        r->status[p] = status;
        r->dropped_lights[size_t(p)] = uint16_t(std::min(n - count, 65535));
        local_refit += status == kTexelOk;
        local_dropped += n - count;
      }
    }
    refit += local_refit, dropped += local_dropped;
  });
  r->refit_texels = refit;
  r->dropped_samples = dropped;
}

}  // namespace matfit::fit
