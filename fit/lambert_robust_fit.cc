// `lambert-robust` (METHODS.md §3): photometric stereo that rejects shadowed and highlight
// samples per texel.
//   1. Rank trimming: fit luminance on the samples ranked between the `trim_dark` and
//      `1 − trim_bright` fractions (cast/attached shadows are dark, highlights bright).
//   2. Reweighting: predicted ŷ_i = max(0, g·l_i), residual r_i = y_i − ŷ_i, robust scale
//      σ = 1.4826 · median |r| over the inliers; inliers are lit (n·l_i > 0.05) with
//      |r_i| ≤ 3σ (+ a noise floor); refit on the inliers, up to 4 rounds.
//   3. The texel is kept only with ≥ 3 inliers whose light directions are well conditioned
//      (smallest/largest eigenvalue of Σ l lᵀ ≥ 1e-3); otherwise it is flagged, not guessed.
// Albedo per channel by 1-D least squares over the final inliers.
//
// Four texels run together, one per vector lane (FitBlock): the sums over the lights, the
// predictions, the inlier tests and the rank cut-offs are lane-wise, each lane doing exactly
// the scalar operations of one texel in the same order (no FMA contraction: fit/CMakeLists.txt),
// so every texel's result is the same as fitting it alone. Only the selections (rank cut-offs,
// medians) and the 3×3 solves run per lane.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <memory>
#include <new>
#include <vector>

#include "core/simd_clones.h"
#include "fit/fit_common.h"
#include "fit/methods.h"
#include "fit/select_kth.h"

namespace matfit::fit {
namespace {

constexpr double kTrimDark = 0.2, kTrimBright = 0.1;
constexpr int kRounds = 4;

// Texels per block. Four: GCC 12 lowers comparisons of 64-byte vectors to scalar code inside a
// target_clones function (32-byte ones stay vector compares).
constexpr int kLanes = 4;
typedef double Vd __attribute__((vector_size(8 * kLanes)));
typedef float Vf __attribute__((vector_size(4 * kLanes)));
typedef int64_t Vm __attribute__((vector_size(8 * kLanes)));  // lane masks: −1 true, 0 false

bool AnyLane(Vm m) {
  int64_t a = 0;
  for (int j = 0; j < kLanes; ++j) a |= m[j];
  return a != 0;
}

inline __attribute__((always_inline)) Vd Abs(Vd v) { return (Vd)((Vm)v & (Vm{} + INT64_MAX)); }

// Light directions and their products l lᵀ, one array per component.
struct LightTable {
  explicit LightTable(const std::vector<Vec3>& d) {
    for (const Vec3& l : d) {
      x.push_back(l.x), y.push_back(l.y), z.push_back(l.z);
      xx.push_back(l.x * l.x), xy.push_back(l.x * l.y), xz.push_back(l.x * l.z);
      yy.push_back(l.y * l.y), yz.push_back(l.y * l.z), zz.push_back(l.z * l.z);
    }
  }
  int size() const { return int(x.size()); }
  std::vector<double> x, y, z, xx, xy, xz, yy, yz, zz;
};

// n lane vectors on 64-byte boundaries: the AVX clones align a Vd to its size, while
// std::vector<Vd> would allocate with the baseline's alignment of 16.
template <typename V>
class LaneVector {
 public:
  explicit LaneVector(size_t n)
      : p_(static_cast<V*>(std::aligned_alloc(64, (n * sizeof(V) + 63) / 64 * 64))) {
    if (!p_) throw std::bad_alloc();
  }
  V& operator[](size_t i) { return p_.get()[i]; }
  const V& operator[](size_t i) const { return p_.get()[i]; }
  V* data() { return p_.get(); }

 private:
  struct Free {
    void operator()(V* p) const { std::free(p); }
  };
  std::unique_ptr<V, Free> p_;
};

// One block's samples, light-major ([i] holds the four texels) and its per-lane results.
struct Block {
  Block(int n, int channels)
      : y(size_t(n)),
        usable(size_t(n)),
        samples(size_t(channels) * n),
        e(size_t(n)),
        keep(size_t(n)),
        next(size_t(n)),
        sel(size_t(n)),
        sel2(size_t(n)),
        scratch(size_t(SelectScratchSize(n))) {}
  // Inputs.
  LaneVector<Vd> y;        // luminance / I (non-finite → 0)
  LaneVector<Vm> usable;   // neither clipped nor non-finite
  LaneVector<Vf> samples;  // [c · n + i] the channel samples (linear)
  bool fit[kLanes] = {};   // lanes to fit (the texel's status is ok)
  // Outputs per lane.
  uint8_t status[kLanes] = {};
  Vec3 normal[kLanes];
  double albedo[kLanes][3] = {};
  // Scratch.
  LaneVector<Vd> e;  // |r_i|
  LaneVector<Vm> keep, next;
  std::vector<double> sel, sel2, scratch;  // selections (SelectKthFinite)
};

// Σ l lᵀ and Σ l y over each lane's kept samples, and their count. Branch-free: a kept sample
// adds its terms, another adds 0 (which samples are kept is data-dependent).
struct LaneSums {
  Vd m00, m01, m02, m11, m12, m22, b0, b1, b2;
  Vm count;
};
inline __attribute__((always_inline)) LaneSums SumSubset(const LightTable& L, const Vd* y,
                                                         const Vm* keep) {
  LaneSums s = {};
  const Vd zero = {};
  for (int i = 0; i < L.size(); ++i) {
    const Vm k = keep[i];
    const Vd x = zero + L.x[i], yy = zero + L.y[i], z = zero + L.z[i];
    s.m00 += k ? zero + L.xx[i] : zero, s.m01 += k ? zero + L.xy[i] : zero;
    s.m02 += k ? zero + L.xz[i] : zero, s.m11 += k ? zero + L.yy[i] : zero;
    s.m12 += k ? zero + L.yz[i] : zero, s.m22 += k ? zero + L.zz[i] : zero;
    s.b0 += k ? x * y[i] : zero, s.b1 += k ? yy * y[i] : zero, s.b2 += k ? z * y[i] : zero;
    s.count -= k;
  }
  return s;
}

// Least squares g of lane j: M g = b. False when fewer than 3 samples or M is singular (smallest
// eigenvalue ≤ 1e-12); *m is M.
bool SolveLane(const LaneSums& s, int j, Vec3* g, Eigen::Matrix3d* m) {
  if (s.count[j] < 3) return false;
  *m << s.m00[j], s.m01[j], s.m02[j], s.m01[j], s.m11[j], s.m12[j], s.m02[j], s.m12[j], s.m22[j];
  // For a positive semi-definite 3×3, λ_min ≥ det / (λ_mid λ_max) ≥ 4 det / tr²: when that bound
  // is far above 1e-12 (its rounding is ~1e-15 tr²) the eigen-decomposition is not needed.
  const double tr = s.m00[j] + s.m11[j] + s.m22[j], det = m->determinant();
  if (!(4 * det >= 1e-6 * tr * tr)) {
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(*m, Eigen::EigenvaluesOnly);
    if (!(eig.eigenvalues()[0] > 1e-12)) return false;
  }
  const Eigen::Vector3d x = m->ldlt().solve(Eigen::Vector3d(s.b0[j], s.b1[j], s.b2[j]));
  *g = {x.x(), x.y(), x.z()};
  return true;
}

// Smallest / largest eigenvalue of M (0 when M vanishes).
double Conditioning(const Eigen::Matrix3d& m) {
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
  eig.computeDirect(m, Eigen::EigenvaluesOnly);
  const auto ev = eig.eigenvalues();  // ascending
  return ev[2] > 0 ? ev[0] / ev[2] : 0;
}

// Per lane, the index of the key (value, index) of rank r in (value, index) order, given v, the
// value of rank r in value order: the (r − #{y < v})-th sample, in index order, of those equal
// to v. Selecting plain values and resolving ties here is about twice as fast as selecting keys.
inline __attribute__((always_inline)) Vm IndexOfRank(const Vd* y, int n, Vd v, int r) {
  Vm below = {};
  for (int i = 0; i < n; ++i) below -= y[i] < v;
  Vm want = r - below, index = Vm{} + n, open = ~Vm{};
  for (int i = 0; i < n; ++i) {
    const Vm eq = y[i] == v, hit = eq & (want == 0) & open;
    index = hit ? Vm{} + i : index;
    open &= ~hit, want += eq;
  }
  return index;
}

// One plane row's samples v (tw texels) into each texel's luminance dst += w · v (the product
// in float, the sum in double), its peak sample (std::max: a NaN sample leaves it, as
// MarkUnfittableTexels does) and, with may_clip, its clipped flags (samples at the file's
// maximum code are never used).
MATFIT_CLONES_V4 void AddRowSamples(const float* __restrict v, float w, int tw, bool may_clip,
                                    double* __restrict dst, float* __restrict peak,
                                    char* __restrict clipped) {
  for (int k = 0; k < tw; ++k) dst[k] += w * v[k];
  for (int k = 0; k < tw; ++k) peak[k] = std::max(peak[k], v[k]);
  if (may_clip)
    for (int k = 0; k < tw; ++k) clipped[k] |= char(v[k] >= kClipLevel);
}

// Texels [k0, k0 + kb) of the row (lum, clip: [i][k]; vals: [c][i][k]; tw texels) into the lanes
// of `b`, light-major; lanes past kb get zeros and are not usable.
MATFIT_CLONES_V4 void LoadBlock(const double* lum, const char* clip, const float* vals, int n,
                                int C, int tw, int k0, int kb, Block& b) {
  for (int i = 0; i < n; ++i) {
    const size_t at = size_t(i) * tw + k0;
    if (kb == kLanes) {
      std::memcpy(&b.y[i], lum + at, sizeof(Vd));
      for (int j = 0; j < kLanes; ++j) b.usable[i][j] = clip[at + j] ? 0 : -1;
      for (int c = 0; c < C; ++c)
        std::memcpy(&b.samples[size_t(c) * n + i], vals + size_t(c) * n * tw + at, sizeof(Vf));
      continue;
    }
    for (int j = 0; j < kLanes; ++j) {
      b.y[i][j] = j < kb ? lum[at + j] : 0.0;
      b.usable[i][j] = j < kb && !clip[at + j] ? -1 : 0;
    }
    for (int c = 0; c < C; ++c) {
      const float* v = vals + size_t(c) * n * tw + at;
      for (int j = 0; j < kLanes; ++j) b.samples[size_t(c) * n + i][j] = j < kb ? v[j] : 0.f;
    }
  }
}

// Fits the lanes of `b` marked `fit` (status, normal, albedo per lane).
MATFIT_CLONES_V4 void FitBlock(const LightTable& L, const float* inv, int C, Block& b) {
  const int n = L.size();
  const Vd zero = {};
  // Non-finite samples (NaN/Inf in any channel: dead pixels, decode holes) are never used; they
  // rank as dark (y = 0), clipped ones keep their value.
  Vm finite = {};  // per lane, the number of finite samples
  for (int i = 0; i < n; ++i) {
    const Vm f = Abs(b.y[i]) <= std::numeric_limits<double>::max();
    finite -= f;
    b.usable[i] &= f;
    b.y[i] = f ? b.y[i] : zero;
  }
  Vm lanes = {};  // lanes to fit
  for (int j = 0; j < kLanes; ++j) {
    b.status[j] = finite[j] < 3 ? kTexelNonFinite : kTexelOk;
    if (b.fit[j] && finite[j] >= 3) lanes[j] = -1;
  }
  for (int i = 0; i < n; ++i) b.usable[i] &= lanes;
  if (!AnyLane(lanes)) return;

  // 1. Rank trimming (keep at least 3 of the middle ranks): the samples ranked [lo, hi) are those
  // between the rank-lo and rank-hi keys (selections, no sort). Ties (shadow zeros, 8-bit codes)
  // break by index, so the kept set is deterministic.
  int lo = int(std::floor(kTrimDark * n)), hi = int(std::ceil((1 - kTrimBright) * n));
  if (hi - lo < 3) lo = std::max(0, std::min(lo, n - 3)), hi = std::min(n, lo + 3);
  Vd v_lo = {}, v_hi = {};
  for (int j = 0; j < kLanes; ++j) {
    if (!lanes[j]) continue;
    for (int i = 0; i < n; ++i) b.sel[i] = b.sel2[i] = b.y[i][j];
    v_lo[j] = SelectKthFinite(b.sel.data(), n, lo, b.scratch.data());
    v_hi[j] = hi < n ? SelectKthFinite(b.sel2.data(), n, hi, b.scratch.data()) : 0.0;
  }
  const Vm first = IndexOfRank(b.y.data(), n, v_lo, lo);
  const Vm end = hi < n ? IndexOfRank(b.y.data(), n, v_hi, hi) : Vm{} + n;
  for (int i = 0; i < n; ++i) {
    const Vd y = b.y[i];
    const Vm before_first = (y < v_lo) | ((y == v_lo) & (i < first));
    const Vm before_end = hi == n ? ~Vm{} : (y < v_hi) | ((y == v_hi) & (i < end));
    b.keep[i] = b.usable[i] & ~before_first & before_end;
  }
  Vec3 g[kLanes];
  Eigen::Matrix3d m[kLanes];
  bool solved[kLanes] = {};
  Vm active = {};  // lanes still reweighting
  {
    const LaneSums s = SumSubset(L, b.y.data(), b.keep.data());
    for (int j = 0; j < kLanes; ++j)
      if (lanes[j] && (solved[j] = SolveLane(s, j, &g[j], &m[j]))) active[j] = -1;
  }

  // 2. Reweighting rounds.
  for (int round = 0; round < kRounds && AnyLane(active); ++round) {
    Vd gx = {}, gy = {}, gz = {}, nx = {}, ny = {}, nz = {}, limit = {};
    for (int j = 0; j < kLanes; ++j) {
      if (!active[j]) continue;
      const Vec3 nn = Normalize(g[j]);
      gx[j] = g[j].x, gy[j] = g[j].y, gz[j] = g[j].z, nx[j] = nn.x, ny[j] = nn.y, nz[j] = nn.z;
    }
    for (int i = 0; i < n; ++i) {
      Vd d = gx * L.x[i] + gy * L.y[i] + gz * L.z[i];  // ŷ_i = max(0, g·l_i)
      d = 0.0 < d ? d : zero;
      b.e[i] = Abs(b.y[i] - d);  // |r_i|
    }
    for (int j = 0; j < kLanes; ++j) {
      if (!active[j]) continue;
      int count = 0;  // the inliers' |r|, compacted branch-free
      for (int i = 0; i < n; ++i) b.sel[count] = b.e[i][j], count += b.keep[i][j] != 0;
      const double sigma =
          1.4826 * SelectKthFinite(b.sel.data(), count, count / 2, b.scratch.data()) +
          1e-3 * Length(g[j]) + 1e-6;
      limit[j] = 3 * sigma;
    }
    Vm differ = {};
    for (int i = 0; i < n; ++i) {
      const Vd lit = nx * L.x[i] + ny * L.y[i] + nz * L.z[i];
      b.next[i] = b.usable[i] & (lit > 0.05) & (b.e[i] <= limit) & active;
      differ |= b.next[i] ^ b.keep[i];
    }
    active &= differ;  // a lane whose inliers did not change has converged
    if (!AnyLane(active)) break;
    const LaneSums s = SumSubset(L, b.y.data(), b.next.data());
    for (int j = 0; j < kLanes; ++j) {
      if (!active[j]) continue;
      Vec3 g2;
      Eigen::Matrix3d m2;
      if (SolveLane(s, j, &g2, &m2))
        g[j] = g2, m[j] = m2;
      else
        active[j] = 0;  // keep the last good subset
    }
    for (int i = 0; i < n; ++i) b.keep[i] = active ? b.next[i] : b.keep[i];
  }

  // 3. Checks, then albedo per channel over the final inliers.
  Vd nx = {}, ny = {}, nz = {};
  Vm ok = {}, inliers = {};
  for (int i = 0; i < n; ++i) inliers -= b.keep[i];
  for (int j = 0; j < kLanes; ++j) {
    if (!lanes[j]) continue;
    const double len = solved[j] ? Length(g[j]) : 0;
    if (!solved[j] || inliers[j] < 3) {
      b.status[j] = kTexelTooFewLights;
    } else if (Conditioning(m[j]) < 1e-3) {
      b.status[j] = kTexelIllConditioned;
    } else if (!(len > 1e-6)) {
      b.status[j] = kTexelNoSignal;
    } else {
      b.normal[j] = g[j] / len;
      nx[j] = b.normal[j].x, ny[j] = b.normal[j].y, nz[j] = b.normal[j].z, ok[j] = -1;
    }
  }
  Vd num[3] = {}, den = {};
  for (int i = 0; i < n; ++i) {
    const Vm k = b.keep[i] & ok;
    Vd si = nx * L.x[i] + ny * L.y[i] + nz * L.z[i];
    si = 0.0 < si ? si : zero;
    den += k ? si * si : zero;
    for (int c = 0; c < C; ++c) {
      const Vd q = __builtin_convertvector(b.samples[size_t(c) * n + i] * inv[i * C + c], Vd);
      num[c] += k ? q * si : zero;
    }
  }
  for (int j = 0; j < kLanes; ++j)
    for (int c = 0; c < 3; ++c)
      b.albedo[j][c] = ok[j] && den[j] > 0 ? num[C == 1 ? 0 : c][j] / den[j] : 0;
}

}  // namespace

StatusOr<FitResult> FitLambertRobust(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  if (n < 3)
    return InvalidArgument(
        "lambert-robust: only " + std::to_string(n) +
        " light(s); at least 3 non-coplanar lights are needed (more for rejection)");
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, "lambert", "lambert-robust", &r);
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<Vec3> dirs(n);
  for (int i = 0; i < n; ++i) dirs[i] = s.lights()[i].direction;
  const LightTable L(dirs);
  const bool may_clip = StackMayBeClipped(s);

  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    const int tw = t.width;
    // The row's samples (linear, [c][i][k]), luminance ([i][k]), clipped flags ([i][k]) and
    // each texel's peak sample, gathered image by image (contiguous rows); texels without signal
    // are flagged (clipped samples are dropped per sample, not flagged: ApplyPeakStatus without
    // clip), the others handed to FitBlock four at a time.
    std::vector<float> vals(size_t(C) * n * tw), peak(static_cast<size_t>(tw));
    std::vector<double> lum(size_t(n) * tw);
    std::vector<char> clip(size_t(n) * tw);
    Block b(n, C);
    for (int row = t.y0; row < t.y0 + t.height; ++row) {
      const int64_t base = int64_t(row) * W + t.x0;
      std::fill(peak.begin(), peak.end(), 0.0f);
      for (int i = 0; i < n; ++i) {
        double* dst = lum.data() + size_t(i) * tw;
        char* cl = clip.data() + size_t(i) * tw;
        std::fill(dst, dst + tw, 0.0);
        std::fill(cl, cl + tw, char(0));
        for (int c = 0; c < C; ++c) {
          const float w = (C == 1 ? 1.0f : kLuma[c]) * inv[i * C + c];
          float* v = vals.data() + (size_t(c) * n + i) * tw;
          const float* src = s.Row(i, c, row, t.x0, tw, v);
          if (src != v) std::copy_n(src, tw, v);
          AddRowSamples(v, w, tw, may_clip, dst, peak.data(), cl);
        }
      }
      ApplyPeakStatus(peak.data(), base, tw, /*clip=*/false, r.status.data());
      for (int k0 = 0; k0 < tw; k0 += kLanes) {
        const int kb = std::min(kLanes, tw - k0);
        bool any = false;
        for (int j = 0; j < kLanes; ++j)
          any |= b.fit[j] = j < kb && r.status[base + k0 + j] == kTexelOk;
        if (!any) continue;  // masked or without signal: nothing to fit
        LoadBlock(lum.data(), clip.data(), vals.data(), n, C, tw, k0, kb, b);
        FitBlock(L, inv.data(), C, b);
        for (int j = 0; j < kb; ++j) {
          const int64_t p = base + k0 + j;
          if (!b.fit[j]) continue;
          r.status[p] = b.status[j];
          if (b.status[j] != kTexelOk) continue;
          for (int c = 0; c < 3; ++c) {
            r.maps.normal.Plane(c)[p] = float(b.normal[j][c]);
            r.maps.albedo.Plane(c)[p] = float(b.albedo[j][c]);
          }
        }
      }
    }
  });
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
