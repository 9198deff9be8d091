// `mean`: per-texel mean colour over all images (the seed's "diffuse texture" t_c). A texel
// with a non-finite sample gets the mean of its finite ones (fit/valid_refit.h); clipped samples
// are kept (a clipped code still bounds the mean from below).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "fit/fit_common.h"
#include "fit/methods.h"
#include "fit/row_kernels.h"
#include "fit/valid_refit.h"

namespace matfit::fit {

StatusOr<FitResult> FitMean(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, "mean", "mean", &r);
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  // One pass over each strip: t_c = Σ_i p_ci / (I_ic · N), streaming whole plane segments.
  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    const int64_t first = int64_t(t.y0) * W, m = t.texels();
    std::vector<float> sum(size_t(C) * m, 0.0f), peak(m, 0.0f);
    StripReader reader(s);
    float w[kMaxRowPlanes];
    for (int c = 0; c < C; ++c) {
      float* acc = sum.data() + size_t(c) * m;
      for (int i0 = 0; i0 < n; i0 += kMaxRowPlanes) {
        const int planes = std::min(kMaxRowPlanes, n - i0);
        for (int q = 0; q < planes; ++q) w[q] = inv[(i0 + q) * C + c] / float(n);
        reader.Group(i0, planes, c, first, m, [&](const float* const* src, int64_t x, int64_t len) {
          float* a = acc + x;
          RowAccumulate(src, planes, len, 1, w, &a, peak.data() + x);
        });
      }
    }
    ApplyPeakStatus(peak.data(), first, m, /*clip=*/false,
                    r.status.data());  // clipped: still a mean
    for (int64_t k = 0; k < m; ++k) {
      const int64_t p = first + k;
      if (r.status[p] != kTexelOk) continue;
      for (int c = 0; c < 3; ++c) {
        const float mean = sum[size_t(C == 1 ? 0 : c) * m + k];
        if (!std::isfinite(mean)) r.status[p] = kTexelNonFinite;
        r.maps.albedo.Plane(c)[p] = std::isfinite(mean) ? mean : 0.0f;
      }
      r.maps.normal.Plane(2)[p] = 1.0f;
    }
  });
  if (ok) {
    RefitOptions refit;
    refit.drop_clipped = false;
    RefitFromValidSamples(
        s, refit,
        [&](const TexelSamples& t, FitResult* out) {
          if (t.valid_count < 1) return uint8_t(kTexelNonFinite);
          for (int c = 0; c < 3; ++c) {
            const int cc = C == 1 ? 0 : c;
            double sum = 0;
            for (int i = 0; i < t.n; ++i) sum += t.obs[i * C + cc];  // invalid lights hold 0
            out->maps.albedo.Plane(c)[t.p] = float(sum / t.valid_count);
          }
          out->maps.normal.Plane(2)[t.p] = 1.0f;
          return uint8_t(kTexelOk);
        },
        &r);
  }
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
