// The glTF bake's per-texel fit (core/pack/gltf_bake.h, steps 1–3): one texel at a time
// (TexelFit: the full search the material's roughness comes from, and the reference), or eight
// texels at a time at a given roughness (BatchFit: the bake's main pass). Internal to the bake.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "core/pack/gltf_lobe.h"

namespace matfit::gltf {

// A prediction v of the model as the fit's sample under a light of weight √w = sw: sw · v, values
// past ±1e3 (a hostile pack) cut there so that no sum overflows, 0 for a texel without an
// estimate (NaN: it bakes to black).
inline float FitSample(float v, float sw) {
  return std::isfinite(v) ? sw * std::clamp(v, -1e3f, 1e3f) : 0.0f;
}

// One texel's samples y (channel c at y[c · padded + k]; K lights, `ch` channels: 1 or 3) and
// the fits of the glTF dielectric to them.
struct TexelFit {
  struct Lobe {
    double r = 1, f0 = 0, err = 0;
    double rho[3] = {0, 0, 0};
  };

  const CapLights& L;
  const Mat3& inv;
  const MsTable& ms;
  int ch;
  std::vector<float> y;
  double yy[3] = {};  // Σ_k y²
  // Scratch per light: the diffuse shape, the lobe's F0 part and rest of the last Solve.
  std::vector<float> d, a, b;
  std::vector<double> lobe;  // the fitted lobe per light (FitTexel's scratch)

  TexelFit(const CapLights& lights, const Mat3& inverse, const MsTable& table, int channels);
  void SamplesSet();  // y is loaded: Σ y²

  // The unit normal of the least-squares Lambertian of the luminance of y − lobe.
  Vec3f LambertNormal(const std::vector<double>* lobe) const;
  // The least-squares (ρ, F0) of shading::GltfDielectricHalf for normal n and roughness r, its
  // squared residual, and (when `residual` is given) the residuals, K per channel.
  Lobe Solve(const Vec3f& n, double r, float* residual = nullptr);
  // The roughness of least residual among `rs`.
  Lobe BestOf(const Vec3f& n, const double* rs, int count);
  // The roughness of least residual: a grid, then golden-section search around its best.
  Lobe BestLobe(const Vec3f& n);
  // Gauss–Newton on the normal's slopes at roughness r (ρ, F0 re-solved at every step).
  Vec3f RefineNormal(Vec3f n, double r, Lobe* best, std::vector<float>* scratch);
  // Every step for one texel at roughness r0 (or searched when r0 ≤ 0): the Lambertian normal,
  // the lobe, the normal of what the lobe leaves, the normal of least residual, the lobe again.
  Lobe FitTexel(double r0, Vec3f* normal, std::vector<float>* scratch);
};

// TexelFit::FitTexel(r0 > 0) for kLanes texels at once: each lane makes exactly the operations
// of that call on its texel, in the same order, and gets the same result bit for bit. The sums
// over the lights stay LobeRun's (one call per lane and solve); the arithmetic between them (the
// normals, the solves' closed forms, the step logic) runs across the lanes.
class BatchFit {
 public:
  static constexpr int kLanes = 8;
  // The results of one lane.
  struct Result {
    float normal[3] = {0, 0, 1};
    double r = 1, f0 = 0;
    double rho[3] = {0, 0, 0};
  };

  BatchFit(const CapLights& lights, const Mat3& inverse, const MsTable& table, int channels);
  // Lane j's samples: FitSample of the predictions pred[(k · ch + c) · stride] (light k < K,
  // channel c < ch), into TexelFit::y's layout and across the lanes.
  void Load(int j, const float* pred, int stride);
  // Load(j, pred + j, stride) for every lane j < kLanes, across the lanes at once.
  void LoadEight(const float* pred, int stride);
  // Fits lanes [0, lanes) at roughness r0 > 0 (their samples set).
  void Fit(int lanes, double r0, Result* out);

 private:
  // Per lane, the figures of one solve (TexelFit::Lobe).
  struct Lobes {
    double f0[kLanes] = {}, err[kLanes] = {}, rho[3][kLanes] = {}, r[kLanes] = {};
  };
  using Mask = bool[kLanes];
  size_t Stride() const { return size_t(3) * L_.padded; }
  float* Samples(int j) { return y_.data() + size_t(j) * Stride(); }
  void LambertNormals(const double* lobe, const Mask on, float* nx, float* ny, float* nz) const;
  void Solve(const float* nx, const float* ny, const float* nz, double r, const Mask on,
             float* const* residual, Lobes* out);
  // `*best` gets `l`'s lane where it is lower, per lane of `on`; `take` says where it did.
  static void KeepLower(const Lobes& l, const Mask on, Lobes* best, bool* take);
  void RefineNormals(const Mask on, double r, float* nx, float* ny, float* nz, Lobes* best);

  const CapLights& L_;
  const Mat3& inv_;
  const MsTable& ms_;
  const int ch_;
  std::vector<float> y_;      // [lane][c · padded + k]
  std::vector<float> ylane_;  // [(c · padded + k) · kLanes + lane]: y across the lanes
  double yy_[3][kLanes] = {};
  std::vector<float> a_, b_, d_;  // [lane][k] of each lane's last solve
  std::vector<double> lobe_;      // [k · kLanes + lane]
  std::vector<float> e_;          // 3 residual sets per lane, 3 · padded each (zero past ch)
};

}  // namespace matfit::gltf
