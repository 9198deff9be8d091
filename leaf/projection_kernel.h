// Inner loop of the fast translucency precompute: HL2 projection of the self-shadowed
// irradiance, ε_i += c_i,m · ρ V(ω_m) max(0, n·ω_m), over a block of texels and all directions.
#pragma once

#include <cstdint>
#include <span>

namespace matfit::leaf {

struct ProjectionDirection {
  float wx = 0, wy = 0, wz = 1;  // ω (lit-side frame)
  float elevation = 0;           // rad, above the tangent plane
  int k0 = 0, k1 = 0;            // horizon slices around ω's azimuth
  float t = 0;                   // weight of k1
  bool shadow = false;           // apply the horizon test
  float c[3] = {0, 0, 0};        // (2π/N_L) ℋ_i(ω)
};

// SoA block of n texels: normals, ρ, horizon angles (slice k at hz + k·hz_stride). Adds into
// s0..s2. Built for AVX2+FMA where the CPU has it (function multi-versioning).
void ProjectIrradianceBlock(const float* nx, const float* ny, const float* nz, const float* rho,
                            const float* hz, int64_t hz_stride, int64_t n,
                            std::span<const ProjectionDirection> dirs, float* s0, float* s1,
                            float* s2);

}  // namespace matfit::leaf
