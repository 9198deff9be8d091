// The glTF bake's light-side building blocks (core/pack/gltf_bake.h): the cap of directions the
// stand-in is fitted over, the GGX lobe split for the linear least squares, and the sums and
// residuals of one texel over those lights. Internal to the bake (compute only).
#pragma once

#include <array>
#include <vector>

#include "core/vec3.h"

namespace matfit::gltf {

using Mat3 = std::array<std::array<double, 3>, 3>;

// Rings every 12° from the zenith to θ = 60°, each with its directions about 12° apart (85).
std::vector<Vec3f> CapDirections();

// (Σ_k l_k l_kᵀ)⁻¹ by cofactors: the directions span the cap, so it is well conditioned.
Mat3 InverseScatter(const std::vector<Vec3f>& dirs);

// 1/E − 1 on r = 0, 1/64, …, 1 (linear in between; r = 0 repeats r = 1/64).
struct MsTable {
  static constexpr int kSteps = 64;
  double c[kSteps + 1];
  MsTable();  // 65 quadratures of 4096 steps (≈ 10 ms on one thread): the entries in parallel
  double operator()(double r) const;
};
// The process's table, computed on first use and kept.
const MsTable& SharedMsTable();

// The cap's lights in SoA, padded to a multiple of 8 with lights below the horizon (zero
// diffuse and lobe: they add nothing to any sum).
struct CapLights {
  int K = 0, padded = 0;
  std::vector<float> lx, ly, lz, hx, hy, hz, w;  // direction, half vector, (1 − v·h)^5
  std::vector<float> sw;                         // √ of the light's weight in the fit
  explicit CapLights(const std::vector<Vec3f>& dirs);
};

// Σ_k of the products the least squares need (y the samples, d the diffuse shape, a and b the
// lobe's F0 part and rest).
struct LobeSums {
  double dd = 0, ad = 0, aa = 0, bd = 0, ba = 0, bb = 0;
  double yd[3] = {}, ya[3] = {}, yb[3] = {};
};

// The lobe of shading::CookTorranceSpecularHalf at F0 = 1 (GgxD, GgxG1 and the Fresnel weight)
// for normal n (n_z > 0) and α = r², split into a = lobe (1 − w) and b = lobe w, the diffuse
// shape d = (1 − w) max(0, n·l), each times √weight, per padded light; and their sums with the
// samples y (channel c at y + c · padded; channels past the texel's are zero). Vectorised over
// the lights; the sums in double, eight partial sums (light k into k mod 8) added in order.
void LobeRun(const CapLights& L, const float* y, float nx, float ny, float nz, float alpha,
             float* a, float* b, float* d, LobeSums* s);

// g = (Σ jx², Σ jx jy, Σ jy², Σ jx e0, Σ jy e0) with jx = (ex − e0) · inv_delta (jy alike),
// over m residuals (a multiple of 8), in eight float partial sums (i into i mod 8).
void GaussNewtonSums(const float* e0, const float* ex, const float* ey, int m, float inv_delta,
                     double* g);

// cols[j][i] = rows[i][j] for an 8 × 8 block of 8-element GCC vectors (float or double): three
// rounds of two-input shuffles. Inlined into the callers' ISA clones.
template <typename V>
__attribute__((always_inline)) inline void Transpose8x8(const V* rows, V* cols) {
  V t[8], u[8];
  for (int i = 0; i < 8; i += 2) {
    t[i] = __builtin_shufflevector(rows[i], rows[i + 1], 0, 8, 2, 10, 4, 12, 6, 14);
    t[i + 1] = __builtin_shufflevector(rows[i], rows[i + 1], 1, 9, 3, 11, 5, 13, 7, 15);
  }
  for (int i = 0; i < 8; i += 4)
    for (int h = 0; h < 2; ++h) {
      u[i + h] = __builtin_shufflevector(t[i + h], t[i + h + 2], 0, 1, 8, 9, 4, 5, 12, 13);
      u[i + h + 2] = __builtin_shufflevector(t[i + h], t[i + h + 2], 2, 3, 10, 11, 6, 7, 14, 15);
    }
  // u[h] (h < 4) holds column h of rows 0–3 and column h + 4 beside them, u[h + 4] the same of
  // rows 4–7.
  for (int h = 0; h < 4; ++h) {
    cols[h] = __builtin_shufflevector(u[h], u[h + 4], 0, 1, 2, 3, 8, 9, 10, 11);
    cols[h + 4] = __builtin_shufflevector(u[h], u[h + 4], 4, 5, 6, 7, 12, 13, 14, 15);
  }
}

// e = y − rp d − fa a − fb b over n lights (float, elementwise).
void LobeResiduals(const float* y, const float* d, const float* a, const float* b, int n, float rp,
                   float fa, float fb, float* e);

}  // namespace matfit::gltf
