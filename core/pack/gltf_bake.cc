#include "core/pack/gltf_bake.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>
#include <numbers>
#include <optional>
#include <vector>

#include "core/model/model.h"
#include "core/pack/gltf_lobe.h"
#include "core/pack/gltf_texel_fit.h"
#include "core/parallel.h"
#include "core/shading/shading.h"

namespace matfit {

using gltf::BatchFit;
using gltf::TexelFit;

GltfBake BakeBasisAsGgx(const MaterialMaps& m, const ProgressFn& progress, BakeLanes lanes) {
  const std::vector<Vec3f> dirs = gltf::CapDirections();
  const gltf::CapLights lights(dirs);
  const int K = int(dirs.size()), P = lights.padded, ch = m.albedo.channels() == 3 ? 3 : 1;
  const gltf::Mat3 inv = gltf::InverseScatter(dirs);
  const gltf::MsTable& ms_table = gltf::SharedMsTable();
  const BatchEvaluator eval(m, dirs, Vec3f(0, 0, 1));
  const int64_t n = int64_t(m.width) * m.height;
  constexpr int kRun = 256;
  // The model's prediction for a run of texels p0 … p0 + len − 1: [k][c][t].
  auto predict = [&](std::vector<float>* pred, int64_t p0, int len) {
    pred->resize(size_t(K) * ch * kRun);
    for (int k = 0; k < K; ++k) eval.Evaluate(k, p0, len, ch, pred->data() + size_t(k) * ch * len);
  };
  // Texel t of the run predicted last as a fit's samples (channel c at y[c · P + k]).
  auto load = [&](const std::vector<float>& pred, int len, int t, float* y) {
    for (int c = 0; c < ch; ++c)
      for (int k = 0; k < K; ++k)
        y[size_t(c * P + k)] =
            gltf::FitSample(pred[(size_t(k) * ch + c) * len + t], lights.sw[size_t(k)]);
  };
  // The material's roughness: the median of full searches on up to 1024 texels spread over the
  // image (inside the mask), where a lobe is found. Texels then search only around it.
  const auto in_mask = [&](int64_t p) { return m.mask.empty() || m.mask.Plane(0)[p] > 0.5f; };
  std::vector<int64_t> sample;
  const int64_t stride = std::max<int64_t>(1, (n + 1023) / 1024);
  for (int64_t p = stride / 2; p < n; p += stride)
    if (in_mask(p)) sample.push_back(p);
  std::vector<double> sample_r(sample.size(), -1);
  ParallelFor(0, int64_t(sample.size()), [&](int64_t i0, int64_t i1) {
    std::vector<float> pred, scratch;
    TexelFit fit(lights, inv, ms_table, ch);
    for (int64_t i = i0; i < i1; ++i) {
      predict(&pred, sample[size_t(i)], 1);
      load(pred, 1, 0, fit.y.data());
      fit.SamplesSet();
      Vec3f nn;
      const TexelFit::Lobe l = fit.FitTexel(0, &nn, &scratch);
      if (l.f0 > 0.005) sample_r[size_t(i)] = l.r;
    }
  });
  std::vector<double> rs;
  for (double r : sample_r)
    if (r > 0) rs.push_back(r);
  double r_material = 0.5;
  if (!rs.empty()) {
    std::nth_element(rs.begin(), rs.begin() + long(rs.size() / 2), rs.end());
    r_material = rs[rs.size() / 2];
  }
  GltfBake out;
  out.base = Image(m.width, m.height, 3);
  out.normal = Image(m.width, m.height, 3);
  out.f0 = Image(m.width, m.height, 1);
  out.roughness = Image(m.width, m.height, 1);
  auto store = [&](int64_t p, const float* nn, double r, double f0, const double* rho) {
    out.normal.Plane(0)[p] = nn[0], out.normal.Plane(1)[p] = nn[1], out.normal.Plane(2)[p] = nn[2];
    for (int c = 0; c < 3; ++c) out.base.Plane(c)[p] = float(rho[std::min(c, ch - 1)]);
    out.f0.Plane(0)[p] = float(f0);
    out.roughness.Plane(0)[p] = float(r);
  };
  const int64_t runs = (n + kRun - 1) / kRun;
  std::atomic<int64_t> runs_done{0};
  std::mutex progress_mutex;
  ParallelFor(0, runs, [&](int64_t r0, int64_t r1) {
    std::vector<float> pred, scratch;
    std::optional<TexelFit> one;
    std::optional<BatchFit> eight;
    if (lanes == BakeLanes::kOneByOne)
      one.emplace(lights, inv, ms_table, ch);
    else
      eight.emplace(lights, inv, ms_table, ch);
    int64_t texel[BatchFit::kLanes];
    BatchFit::Result result[BatchFit::kLanes];
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t p0 = r * kRun;
      const int len = int(std::min<int64_t>(kRun, n - p0));
      predict(&pred, p0, len);
      // The run's texels inside the mask, kLanes at a time (or one at a time).
      int filled = 0;
      auto flush = [&] {
        eight->Fit(filled, r_material, result);
        for (int j = 0; j < filled; ++j)
          store(texel[j], result[j].normal, result[j].r, result[j].f0, result[j].rho);
        filled = 0;
      };
      for (int t = 0; t < len; ++t) {
        const int64_t p = p0 + t;
        if (!in_mask(p)) {  // outside the sample: black, facing up, no lobe
          out.normal.Plane(2)[p] = 1, out.roughness.Plane(0)[p] = 1;
          continue;
        }
        if (lanes == BakeLanes::kOneByOne) {
          load(pred, len, t, one->y.data());
          one->SamplesSet();
          Vec3f nn;
          const TexelFit::Lobe best = one->FitTexel(r_material, &nn, &scratch);
          const float normal[3] = {nn.x, nn.y, nn.z};
          store(p, normal, best.r, best.f0, best.rho);
          continue;
        }
        // Eight texels in a row inside the mask load at once.
        bool in_a_row = filled == 0 && t + BatchFit::kLanes <= len;
        for (int j = 1; in_a_row && j < BatchFit::kLanes; ++j) in_a_row = in_mask(p + j);
        if (in_a_row) {
          eight->LoadEight(pred.data() + t, len);
          for (int j = 0; j < BatchFit::kLanes; ++j) texel[j] = p + j;
          filled = BatchFit::kLanes;
          t += BatchFit::kLanes - 1;
        } else {
          eight->Load(filled, pred.data() + t, len);
          texel[filled++] = p;
        }
        if (filled == BatchFit::kLanes) flush();
      }
      if (filled > 0) flush();
      const int64_t d = ++runs_done;
      if (progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        (void)progress(d, runs);
      }
    }
  });
  return out;
}

double GgxAlbedoHeadOn(double roughness) {
  roughness = std::clamp(roughness, 1.0 / 64, 1.0);  // sharper lobes: below float n·h resolution
  // E = 2 ∫_0^{π/2} R_s(θ) sin θ dθ with θ = (π/2) u² (dense where sharp lobes are), midpoints.
  constexpr int kSteps = 4096;
  const Vec3f n(0, 0, 1);
  double e = 0;
  for (int i = 0; i < kSteps; ++i) {
    const double u = (i + 0.5) / kSteps, t = std::numbers::pi / 2 * u * u;
    const Vec3f l(float(std::sin(t)), 0, float(std::cos(t)));
    e += shading::CookTorranceSpecular(1.0f, float(roughness), n, l, n) * std::sin(t) *
         (std::numbers::pi * u / kSteps);
  }
  return 2 * e;
}

double SelfConsistentF0(double u, double v, double c) {
  const double g0 = u - v;  // F0 at κ = 1
  if (!(g0 > 0)) return 0;
  if (c == 0) return std::min(g0, 0.81);
  // c > 0: the positive root (the roots' product (v − u) / c is negative), without cancellation
  // as 2 g0 / (lin + √disc) when lin ≥ 0. c < 0 (a quadrature E(r) a hair above 1): the root that
  // tends to g0 as c → 0, the same expression. The point the iteration F0 ← u / κ − v reaches
  // when it converges (at |slope| ≥ 1 it oscillates instead).
  const double lin = 1 + c * v, disc = lin * lin + 4 * c * g0;
  double f0;
  if (c > 0)
    f0 = lin >= 0 ? 2 * g0 / (lin + std::sqrt(disc)) : (std::sqrt(disc) - lin) / (2 * c);
  else
    f0 = disc >= 0 && lin > 0 ? 2 * g0 / (lin + std::sqrt(disc)) : g0;
  return std::min(f0, 0.81);
}

GltfF0 SplitF0ForGltf(const Image& f0, const Image& mask) {
  GltfF0 out;
  if (f0.empty()) return out;
  std::vector<float> sorted;
  sorted.reserve(size_t(f0.plane_size()));
  const bool masked = mask.plane_size() == f0.plane_size();
  for (int64_t p = 0; p < f0.plane_size(); ++p)
    if (const float x = f0.Plane(0)[p]; std::isfinite(x) && (!masked || mask.Plane(0)[p] > 0.5f))
      sorted.push_back(std::max(0.0f, x));
  if (sorted.empty()) return out;
  const size_t k = std::min(sorted.size() - 1, sorted.size() * 99 / 100);
  std::nth_element(sorted.begin(), sorted.begin() + long(k), sorted.end());
  const double ref = std::min(double(sorted[k]), 0.81);
  if (!(ref > 0)) return out;
  const double r0 = std::sqrt(ref);
  out.ior = (1 + r0) / (1 - r0);
  out.share = Image(f0.width(), f0.height(), 1);
  for (int64_t p = 0; p < f0.plane_size(); ++p) {
    const float x = f0.Plane(0)[p];
    out.share.Plane(0)[p] = std::isfinite(x) ? float(std::clamp(x / ref, 0.0, 1.0)) : 0.0f;
  }
  return out;
}

}  // namespace matfit
