#include "leaf/projection_kernel.h"

#include <algorithm>

#include "core/simd_clones.h"
#include "leaf/horizon.h"

namespace matfit::leaf {

MATFIT_CLONES_V3
void ProjectIrradianceBlock(const float* __restrict nx, const float* __restrict ny,
                            const float* __restrict nz, const float* __restrict rho,
                            const float* __restrict hz, int64_t hz_stride, int64_t n,
                            std::span<const ProjectionDirection> dirs, float* __restrict s0,
                            float* __restrict s1, float* __restrict s2) {
  for (const ProjectionDirection& d : dirs) {
    const float wx = d.wx, wy = d.wy, wz = d.wz, c0 = d.c[0], c1 = d.c[1], c2 = d.c[2];
    if (d.shadow) {
      const float* __restrict h0 = hz + d.k0 * hz_stride;
      const float* __restrict h1 = hz + d.k1 * hz_stride;
      const float t = d.t, el = d.elevation;
      for (int64_t j = 0; j < n; ++j) {
        // SoftVisibility(el, horizon), spelled out so that the loop vectorises.
        float v = (el - (h0[j] + (h1[j] - h0[j]) * t)) * kSoftInvWidth + 0.5f;
        v = std::min(1.0f, std::max(0.0f, v));
        const float e = rho[j] * std::max(0.0f, nx[j] * wx + ny[j] * wy + nz[j] * wz) * v;
        s0[j] += c0 * e, s1[j] += c1 * e, s2[j] += c2 * e;
      }
    } else {
      for (int64_t j = 0; j < n; ++j) {
        const float e = rho[j] * std::max(0.0f, nx[j] * wx + ny[j] * wy + nz[j] * wz);
        s0[j] += c0 * e, s1[j] += c1 * e, s2[j] += c2 * e;
      }
    }
  }
}

}  // namespace matfit::leaf
