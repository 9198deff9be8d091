#include "core/pack/gltf_lobe.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <memory>
#include <numbers>

#include "core/pack/gltf_bake.h"
#include "core/parallel.h"
#include "core/shading/shading.h"
#include "core/simd_clones.h"

namespace matfit::gltf {
namespace {
constexpr double kDeg = std::numbers::pi / 180;
}  // namespace

std::vector<Vec3f> CapDirections() {
  constexpr double kSpacing = 12;  // degrees: 85 directions
  std::vector<Vec3f> dirs{Vec3f(0, 0, 1)};
  for (int ring = 1; ring * kSpacing <= 60.01; ++ring) {
    const double t = ring * kSpacing * kDeg;
    const int count =
        std::max(6, int(std::lround(2 * std::numbers::pi * std::sin(t) / (kSpacing * kDeg))));
    for (int k = 0; k < count; ++k) {
      const double p = 2 * std::numbers::pi * k / count;
      dirs.push_back(Vec3f(float(std::sin(t) * std::cos(p)), float(std::sin(t) * std::sin(p)),
                           float(std::cos(t))));
    }
  }
  return dirs;
}

Mat3 InverseScatter(const std::vector<Vec3f>& dirs) {
  Mat3 a{};
  for (const Vec3f& l : dirs)
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a[i][j] += double((&l.x)[i]) * double((&l.x)[j]);
  const double det = a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
                     a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
                     a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
  Mat3 inv;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
      inv[i][j] = (a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1]) / det;
    }
  return inv;
}

MsTable::MsTable() {
  ParallelFor(0, kSteps + 1, [&](int64_t i0, int64_t i1) {
    for (int64_t i = i0; i < i1; ++i)
      c[i] = 1 / GgxAlbedoHeadOn(double(std::max<int64_t>(i, 1)) / kSteps) - 1;
  });
}

double MsTable::operator()(double r) const {
  const double x = std::clamp(r, 0.0, 1.0) * kSteps;
  const int i = std::min(int(x), kSteps - 1);
  return c[i] + (x - i) * (c[i + 1] - c[i]);
}

// Not a function-local static: its initialisation would hold a lock while its ParallelFor runs,
// and a thread waiting there may run another caller's range that needs the table (a recursive
// initialisation). Instead each first caller computes one with no lock held and the first to
// finish publishes it (kept for the process).
const MsTable& SharedMsTable() {
  static std::atomic<const MsTable*> shared{nullptr};  // constant-initialised: no guard
  if (const MsTable* t = shared.load(std::memory_order_acquire)) return *t;
  auto fresh = std::make_unique<const MsTable>();
  const MsTable* expected = nullptr;
  if (shared.compare_exchange_strong(expected, fresh.get(), std::memory_order_acq_rel))
    return *fresh.release();
  return *expected;  // another thread published first
}

CapLights::CapLights(const std::vector<Vec3f>& dirs) : K(int(dirs.size())) {
  padded = (K + 7) / 8 * 8;
  const Vec3f v(0, 0, 1);
  for (int k = 0; k < padded; ++k) {
    const Vec3f l = k < K ? dirs[size_t(k)] : Vec3f(0, 0, -1);
    const Vec3f h = k < K ? Normalize(l + v) : Vec3f(0, 0, 1);
    lx.push_back(l.x), ly.push_back(l.y), lz.push_back(l.z);
    hx.push_back(h.x), hy.push_back(h.y), hz.push_back(h.z);
    w.push_back(k < K ? shading::SchlickFresnel(0.0f, Dot(v, h)) : 0.0f);
    sw.push_back(k < K ? std::sqrt(l.z) : 0.0f);  // weight cos θ: the light's irradiance
  }
}

// Branch-free over the lights so that it vectorises. View straight down: n·v = n_z > 0.
MATFIT_CLONES_V4 void LobeRun(const CapLights& L, const float* y, float nx, float ny, float nz,
                              float alpha, float* __restrict a, float* __restrict b,
                              float* __restrict d, LobeSums* s) {
  const float g1v = shading::GgxG1(nz, alpha), scale = float(M_PI) * g1v / (4 * nz);
  const float *lx = L.lx.data(), *ly = L.ly.data(), *lz = L.lz.data(), *hx = L.hx.data(),
              *hy = L.hy.data(), *hz = L.hz.data(), *w = L.w.data(), *sw = L.sw.data();
  const int np = L.padded;
  for (int k = 0; k < np; ++k) {
    const float nl = nx * lx[k] + ny * ly[k] + nz * lz[k],
                nh = nx * hx[k] + ny * hy[k] + nz * hz[k];
    // max(0, x) as (x + |x|) / 2: GCC 12 vectorises neither the ternary nor fmaxf here.
    const float nlc = 0.5f * (nl + std::fabs(nl)), nhc = 0.5f * (nh + std::fabs(nh));
    // G1(0) = 0: a light below the horizon gets no lobe without a branch.
    const float lobe = scale * shading::GgxD(nhc, alpha) * shading::GgxG1(nlc, alpha);
    a[k] = sw[k] * lobe * (1 - w[k]), b[k] = sw[k] * lobe * w[k], d[k] = sw[k] * nlc * (1 - w[k]);
  }
  // Lane-wise partial sums in double (light k into lane k mod 8; float sums lose the residual of
  // a sharp lobe, whose peak terms reach 1e4), then added across the lanes in lane order. As
  // 64-byte vectors: one register per sum in the AVX-512 clone (as arrays, GCC kept them in
  // 32-byte halves and spilled).
  typedef double V8d __attribute__((vector_size(64)));
  typedef float V8f __attribute__((vector_size(32)));
  constexpr int kTerms = 15;
  V8d acc[kTerms] = {};
  const float *y0 = y, *y1 = y + np, *y2 = y + 2 * np;  // channels past ch are zero
  for (int k0 = 0; k0 < np; k0 += 8) {
    V8f df, af, bf, y0f, y1f, y2f;
    std::memcpy(&df, d + k0, sizeof df), std::memcpy(&af, a + k0, sizeof af);
    std::memcpy(&bf, b + k0, sizeof bf), std::memcpy(&y0f, y0 + k0, sizeof y0f);
    std::memcpy(&y1f, y1 + k0, sizeof y1f), std::memcpy(&y2f, y2 + k0, sizeof y2f);
    const V8d dk = __builtin_convertvector(df, V8d), ak = __builtin_convertvector(af, V8d),
              bk = __builtin_convertvector(bf, V8d), y0k = __builtin_convertvector(y0f, V8d),
              y1k = __builtin_convertvector(y1f, V8d), y2k = __builtin_convertvector(y2f, V8d);
    acc[0] += dk * dk, acc[1] += ak * dk, acc[2] += ak * ak;
    acc[3] += bk * dk, acc[4] += bk * ak, acc[5] += bk * bk;
    acc[6] += y0k * dk, acc[9] += y0k * ak, acc[12] += y0k * bk;
    acc[7] += y1k * dk, acc[10] += y1k * ak, acc[13] += y1k * bk;
    acc[8] += y2k * dk, acc[11] += y2k * ak, acc[14] += y2k * bk;
  }
  // t[i] = acc[i][0] + acc[i][1] + … + acc[i][7] in that order (acc is never −0, so this is
  // also 0 + acc[i][0] + …), for eight sums at a time: the 8 × 8 blocks of acc transposed.
  double t[16];
  for (int block = 0; block < 2; ++block) {
    V8d r[8];
    for (int i = 0; i < 8; ++i) r[i] = 8 * block + i < kTerms ? acc[8 * block + i] : V8d{};
    V8d col[8];  // col[j][i] = r[i][j]
    Transpose8x8(r, col);
    V8d sum = col[0];
    for (int j = 1; j < 8; ++j) sum += col[j];
    std::memcpy(t + 8 * block, &sum, sizeof sum);
  }
  s->dd = t[0], s->ad = t[1], s->aa = t[2], s->bd = t[3], s->ba = t[4], s->bb = t[5];
  for (int c = 0; c < 3; ++c) s->yd[c] = t[6 + c], s->ya[c] = t[9 + c], s->yb[c] = t[12 + c];
}

MATFIT_CLONES_V3 void GaussNewtonSums(const float* __restrict e0, const float* __restrict ex,
                                      const float* __restrict ey, int m, float inv_delta,
                                      double* g) {
  constexpr int kLanes = 8;
  float acc[5][kLanes] = {};
  for (int i0 = 0; i0 < m; i0 += kLanes)
    for (int j = 0; j < kLanes; ++j) {
      const int i = i0 + j;
      const float jx = (ex[i] - e0[i]) * inv_delta, jy = (ey[i] - e0[i]) * inv_delta;
      acc[0][j] += jx * jx, acc[1][j] += jx * jy, acc[2][j] += jy * jy;
      acc[3][j] += jx * e0[i], acc[4][j] += jy * e0[i];
    }
  for (int t = 0; t < 5; ++t) {
    g[t] = 0;
    for (int j = 0; j < kLanes; ++j) g[t] += acc[t][j];
  }
}

MATFIT_CLONES_V4 void LobeResiduals(const float* __restrict y, const float* __restrict d,
                                    const float* __restrict a, const float* __restrict b, int n,
                                    float rp, float fa, float fb, float* __restrict e) {
  for (int j = 0; j < n; ++j) e[j] = y[j] - rp * d[j] - fa * a[j] - fb * b[j];
}

}  // namespace matfit::gltf
