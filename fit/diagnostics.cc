#include "fit/diagnostics.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "core/color.h"
#include "core/comm.h"
#include "core/near_lights.h"
#include "core/parallel.h"
#include "core/simd_clones.h"
#include "core/stack_probe.h"
#include "core/warnings.h"
#include "fit/fit_common.h"
#include "fit/light_cover.h"

namespace matfit::fit {
namespace {

typedef float V8f __attribute__((vector_size(32)));
typedef int V8i __attribute__((vector_size(32)));
typedef double V4d __attribute__((vector_size(32)));
constexpr int kLanes = 8;

// The sampled texels, structure of arrays: texel x owns samples [begin[x], begin[x + 1]), a
// multiple of 8 padded with log2 p = −∞ (which gives y = 0 and no weight); directions l and
// log2 p of each sample (p = relative luminance in (0, 1]), and A_x = Σ l lᵀ, which does not
// depend on γ.
struct SampledTexels {
  std::vector<int64_t> begin{0};
  std::vector<int> count;
  // log2 of the relative value as read, and of the same samples with an sRGB decode applied to
  // each channel (as if the files were sRGB-encoded and read as linear) or an sRGB encode (as if
  // linear files had been decoded as sRGB).
  std::vector<float> lx, ly, lz, log2p, log2p_decoded, log2p_encoded;
  std::vector<Eigen::LDLT<Eigen::Matrix3d>> ldlt;
  std::vector<Eigen::Matrix3d> gram;  // what each ldlt factors (to rebuild it after a transfer)
  size_t size() const { return count.size(); }
};

// The sampled rows as bytes and back (the bands of a distributed stack gather them).
template <typename T>
void PutVector(const std::vector<T>& v, std::string* out) {
  const uint64_t n = v.size();
  out->append(reinterpret_cast<const char*>(&n), sizeof n);
  out->append(reinterpret_cast<const char*>(v.data()), n * sizeof(T));
}
template <typename T>
bool GetVector(const std::string& in, size_t* at, std::vector<T>* v) {
  uint64_t n = 0;
  if (in.size() - *at < sizeof n) return false;
  std::memcpy(&n, in.data() + *at, sizeof n);
  *at += sizeof n;
  if ((in.size() - *at) / sizeof(T) < n) return false;
  v->resize(size_t(n));
  if (n > 0) std::memcpy(v->data(), in.data() + *at, size_t(n) * sizeof(T));
  *at += size_t(n) * sizeof(T);
  return true;
}
std::string PackRows(const std::vector<SampledTexels>& rows) {
  std::string out;
  for (const SampledTexels& r : rows) {
    PutVector(r.begin, &out), PutVector(r.count, &out);
    for (const auto* v : {&r.lx, &r.ly, &r.lz, &r.log2p, &r.log2p_decoded, &r.log2p_encoded})
      PutVector(*v, &out);
    std::vector<double> gram;  // 9 per texel, column-major
    for (const Eigen::Matrix3d& A : r.gram) gram.insert(gram.end(), A.data(), A.data() + 9);
    PutVector(gram, &out);
  }
  return out;
}
void UnpackRows(const std::string& in, std::vector<SampledTexels>* rows) {
  size_t at = 0;
  while (at < in.size()) {
    SampledTexels r;
    bool ok = GetVector(in, &at, &r.begin) && GetVector(in, &at, &r.count);
    for (auto* v : {&r.lx, &r.ly, &r.lz, &r.log2p, &r.log2p_decoded, &r.log2p_encoded})
      ok = ok && GetVector(in, &at, v);
    std::vector<double> gram;
    ok = ok && GetVector(in, &at, &gram) && gram.size() == 9 * r.count.size();
    MATFIT_CHECK(ok, "DiagnoseStack: a band's sampled rows are truncated");
    for (size_t k = 0; k < r.count.size(); ++k) {
      r.gram.push_back(Eigen::Map<const Eigen::Matrix3d>(gram.data() + 9 * k));
      r.ldlt.emplace_back(r.gram.back());
    }
    rows->push_back(std::move(r));
  }
}

// 2^x for x ≤ 0 (relative error < 3e-7), 0 below −125: 2^x = 2^n · e^{f ln 2} with n the
// nearest integer, f ∈ [−½, ½], e^t by its degree-6 Taylor polynomial (|t| ≤ 0.35).
__attribute__((always_inline)) inline void Exp2(const V8f& x, V8f* out) {
  const V8f xc = x < -125.0f ? V8f{} - 125.0f : (x > 0.0f ? V8f{} : x);
  const V8i n = __builtin_convertvector(xc - 0.5f, V8i);  // toward 0: ⌈x − ½⌉, as x ≤ 0
  const V8f t = (xc - __builtin_convertvector(n, V8f)) * 0.69314718f;
  V8f e = V8f{} + 1.0f / 720.0f;
  for (const float c : {1.0f / 120.0f, 1.0f / 24.0f, 1.0f / 6.0f, 0.5f, 1.0f, 1.0f}) e = e * t + c;
  const V8i bits = (n + 127) << 23;
  V8f scale;
  std::memcpy(&scale, &bits, sizeof scale);
  *out = x < -125.0f ? V8f{} : e * scale;
}

// Pooled relative residual Σ_x Σ (y − l·g_x)² / Σ_x Σ (y − ȳ_x)² of per-texel least squares on
// y = p^γ: the share of each texel's variation over lights that n·l does not explain (the
// variance, not the energy, so γ → 0, where y flattens to a constant, is not favoured). One pass
// per texel: y in float, the sums Σy, Σy², Σy·l in double, then Σ(y − l·g)² = Σy² − bᵀg with
// b = Σy·l, g = A⁻¹b, and Σ(y − ȳ)² = Σy² − (Σy)²/n. This part: texels [x0, x1) of one set.
enum Curve { kAsRead = 0, kSrgbDecoded = 1, kSrgbEncoded = 2 };

// A tone curve on [0, 1] tabulated at 4096 intervals, looked up with linear interpolation (the
// γ check applies one to each channel of ~10⁶ sampled values; exact pow per value cost ~30 ms).
// Largest error: ~2e-5 absolute for the sRGB encode just above its linear toe; a diagnostic.
class CurveTable {
 public:
  explicit CurveTable(float (*f)(float)) {
    for (int k = 0; k <= kSteps; ++k) t_[size_t(k)] = f(float(k) / kSteps);
  }
  float operator()(float x) const {
    const float u = (x > 0.0f ? std::min(x, 1.0f) : 0.0f) * kSteps;  // NaN → 0
    const int k = std::min(int(u), kSteps - 1);
    return t_[size_t(k)] + (u - float(k)) * (t_[size_t(k) + 1] - t_[size_t(k)]);
  }

 private:
  static constexpr int kSteps = 4096;
  std::array<float, kSteps + 1> t_;
};

MATFIT_CLONES_V3
void ResidualChunk(const SampledTexels& s, float gamma, Curve curve, size_t x0, size_t x1,
                   double* num, double* den) {
  *num = 0, *den = 0;
  const std::vector<float>& log2p = curve == kAsRead        ? s.log2p
                                    : curve == kSrgbDecoded ? s.log2p_decoded
                                                            : s.log2p_encoded;
  for (size_t x = x0; x < x1; ++x) {
    V4d sy{}, syy{}, sx{}, sly{}, slz{};
    for (int64_t k = s.begin[x]; k < s.begin[x + 1]; k += kLanes) {
      V8f lg, a, b, c;
      std::memcpy(&lg, &log2p[size_t(k)], sizeof lg);
      std::memcpy(&a, &s.lx[size_t(k)], sizeof a);
      std::memcpy(&b, &s.ly[size_t(k)], sizeof b);
      std::memcpy(&c, &s.lz[size_t(k)], sizeof c);
      V8f y;
      Exp2(gamma * lg, &y);
      for (int h = 0; h < 2; ++h) {
        const V4d yd = h ? V4d{y[4], y[5], y[6], y[7]} : V4d{y[0], y[1], y[2], y[3]};
        const V4d ad = h ? V4d{a[4], a[5], a[6], a[7]} : V4d{a[0], a[1], a[2], a[3]};
        const V4d bd = h ? V4d{b[4], b[5], b[6], b[7]} : V4d{b[0], b[1], b[2], b[3]};
        const V4d cd = h ? V4d{c[4], c[5], c[6], c[7]} : V4d{c[0], c[1], c[2], c[3]};
        sy += yd, syy += yd * yd, sx += yd * ad, sly += yd * bd, slz += yd * cd;
      }
    }
    auto total = [](V4d v) { return (v[0] + v[2]) + (v[1] + v[3]); };
    const Eigen::Vector3d bvec(total(sx), total(sly), total(slz));
    const Eigen::Vector3d g = s.ldlt[x].solve(bvec);
    const double yy = total(syy), y1 = total(sy);
    *num += std::max(0.0, yy - bvec.dot(g));
    *den += std::max(0.0, yy - y1 * y1 / s.count[x]);
  }
}

// Over the sampled rows in parallel, summed in row order (the same for any thread count).
double LambertResidual(const std::vector<SampledTexels>& rows, double gamma,
                       Curve curve = kAsRead) {
  std::vector<double> nums(rows.size(), 0.0), dens(rows.size(), 0.0);
  ParallelFor(0, int64_t(rows.size()), [&](int64_t r0, int64_t r1) {
    for (int64_t r = r0; r < r1; ++r) {
      const SampledTexels& row = rows[size_t(r)];
      ResidualChunk(row, float(gamma), curve, 0, row.size(), &nums[size_t(r)], &dens[size_t(r)]);
    }
  });
  double num = 0, den = 0;
  for (size_t r = 0; r < rows.size(); ++r) num += nums[r], den += dens[r];
  return den > 0 ? num / den : 0;
}

// One texel's samples: y = luminance / I per usable light (finite, unclipped, lit from above,
// above 1e-3), sorted, the darker middle ranks [5 %, 40 %) kept (at least 6), relative to the
// largest kept. Highlights and the gloss around them sit in the upper ranks and bias γ̂ low on
// glossy materials (plastic, as read linear: γ̂ 0.89 with [10 %, 75 %), 0.997 with these);
// cast shadows in the lowest. yd and ye hold the same samples through the sRGB decode / encode.
// False when fewer than 6 remain.
struct TexelCollector {
  std::vector<std::pair<double, int>> v;
  // lvec: the texel's own light vectors (near lights: f · its direction to each lamp, the
  // fall-off folded in so that n · l is the Lambertian term); null: the lights' directions.
  bool Add(const LightStack& s, const double* yd, const double* ye, const Vec3* lvec,
           SampledTexels* out) {
    if (v.size() < 8) return false;
    std::sort(v.begin(), v.end());
    const size_t lo = v.size() / 20;
    const size_t hi = std::min(v.size(), std::max(v.size() * 2 / 5, lo + 6));
    if (hi - lo < 6) return false;
    const double scale = 1.0 / v[hi - 1].first;  // γ acts on relative values
    double scale_d = 0, scale_e = 0;
    for (size_t k = lo; k < hi; ++k)
      scale_d = std::max(scale_d, yd[v[k].second]), scale_e = std::max(scale_e, ye[v[k].second]);
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    for (size_t k = lo; k < hi; ++k) {
      const int i = v[k].second;
      const Vec3& dir = lvec ? lvec[i] : s.lights()[size_t(i)].direction;
      const Eigen::Vector3d l(dir.x, dir.y, dir.z);
      out->lx.push_back(float(dir.x)), out->ly.push_back(float(dir.y));
      out->lz.push_back(float(dir.z));
      out->log2p.push_back(float(std::log2(v[k].first * scale)));
      out->log2p_decoded.push_back(float(std::log2(yd[i] / scale_d)));
      out->log2p_encoded.push_back(float(std::log2(ye[i] / scale_e)));
      A += l * l.transpose();
    }
    const size_t padded = (out->lx.size() + kLanes - 1) / kLanes * kLanes;
    out->lx.resize(padded, 0.0f), out->ly.resize(padded, 0.0f), out->lz.resize(padded, 0.0f);
    for (auto* lp : {&out->log2p, &out->log2p_decoded, &out->log2p_encoded})
      lp->resize(padded, -std::numeric_limits<float>::infinity());
    out->begin.push_back(int64_t(padded));
    out->count.push_back(int(hi - lo));
    out->ldlt.emplace_back(A);
    out->gram.push_back(A);
    return true;
  }
};

}  // namespace

StackDiagnostics DiagnoseStack(const LightStack& s, int max_texels) {
  // A multi-view stack is diagnosed on its most frontal view: the tone-curve estimate fits a
  // Lambertian per texel, which the other views' Fresnel and masking would bend (a linear
  // lacquer BTF read as γ 1.21, "sRGB read as linear", over all its views).
  if (s.is_multi_view()) {
    const auto groups = ViewGroups(s);
    return DiagnoseStack(BorrowImages(s, groups[size_t(MostFrontalView(s, groups))]), max_texels);
  }
  StackDiagnostics d;
  const int n = s.num_images(), C = s.channels(), W = s.width();
  if (n < 6) return d;
  // A regular 2-D grid of about max_texels texels (a 1-D stride would pick a few columns),
  // gathered row by row (sequential reads of each plane), rows in parallel, kept in row order.
  // The grid is the whole stack's: a band samples its rows of it, and the bands' rows are
  // gathered in order below. A stack whose loader took the grid's codes while decoding
  // (LightStack::probe) is read from those: the same codes, without a miss per plane row.
  const ProbeGrid grid = MakeProbeGrid(W, s.full_height(), s.band.row0, s.height(), max_texels);
  const std::vector<int>&xs = grid.xs, &ys = grid.ys;
  const StackProbe* probe = s.probe && !s.is_float() && s.probe->images == n &&
                                    s.probe->channels == C && s.probe->grid == grid
                                ? s.probe.get()
                                : nullptr;
  const bool clip = StackMayBeClipped(s);
  const bool near = s.has_light_positions();  // each texel under its own lamp directions
  const std::vector<float> inv = InverseIntensities(s);
  const int X = int(xs.size());
  std::vector<SampledTexels> texels(ys.size());  // per sampled row
  static const CurveTable decode(&SrgbToLinear), encode(&LinearToSrgb);
  auto Usable = [&](float raw) { return std::isfinite(raw) && !(clip && raw >= kClipLevel); };
  // An integer stack's samples are its codes' values: the linear value, its sRGB decode and
  // encode and whether it is usable, once per code (the same floats as per sample).
  struct CodeValues {
    float raw, decoded, encoded;
    bool usable;
  };
  std::vector<CodeValues> codes(s.lut().size());
  for (size_t k = 0; k < codes.size(); ++k) {
    const float raw = s.lut()[k];
    codes[k] = {raw, decode(raw), encode(raw), Usable(raw)};
  }
  ParallelFor(0, int64_t(ys.size()), [&](int64_t r0, int64_t r1) {
    std::vector<double> y(size_t(X) * n), yd(size_t(X) * n), ye(size_t(X) * n);
    std::vector<char> good(size_t(X) * n);
    std::vector<Vec3> lvec(near ? size_t(n) : 0);
    TexelCollector collect;
    for (int64_t r = r0; r < r1; ++r) {
      const int64_t row = int64_t(ys[size_t(r)]) * W;
      SampledTexels& out = texels[size_t(r)];
      const size_t most = size_t(X) * ((n + kLanes - 1) / kLanes * kLanes);  // no regrowth
      for (auto* v :
           {&out.lx, &out.ly, &out.lz, &out.log2p, &out.log2p_decoded, &out.log2p_encoded})
        v->reserve(most);
      const int64_t span = X ? xs.back() - xs.front() + 1 : 0;  // the row's sampled columns
      for (int i = 0; i < n; ++i) {
        // Two images ahead: each plane's row is a DRAM miss the loads below would wait for.
        if (!probe && i + 2 < n && span > 0)
          for (int c = 0; c < C; ++c) s.Prefetch(i + 2, c, row + xs.front(), int(span));
        const bool lit = s.lights()[size_t(i)].direction.z > 0;
        for (int k = 0; k < X; ++k) {
          const size_t at = size_t(k) * n + i;
          y[at] = yd[at] = ye[at] = 0, good[at] = lit;
        }
        for (int c = 0; c < C; ++c) {
          const float w = (C == 3 ? kLuma[c] : 1.0f) * inv[size_t(i) * C + c];
          // Integer stacks: every per-sample value from the code's row of `codes`; code_of(k)
          // is column xs[k]'s code (from the probe, or the plane).
          auto gather_codes = [&](const auto& code_of) {
            for (int k = 0; k < X; ++k) {
              const CodeValues& v = codes[code_of(k)];
              const size_t at = size_t(k) * n + i;
              good[at] = good[at] && v.usable;
              y[at] += w * v.raw, yd[at] += w * v.decoded, ye[at] += w * v.encoded;
            }
          };
          auto from_plane = [&](const auto* plane) {
            gather_codes([&](int k) { return plane[row + xs[size_t(k)]]; });
          };
          if (probe) {
            gather_codes([&](int k) { return probe->Code(int(r), i, c, k); });
          } else if (s.sample_type() == SampleType::kUint8) {
            from_plane(s.Codes<uint8_t>(i, c).data());
          } else if (s.sample_type() == SampleType::kUint16) {
            from_plane(s.Codes<uint16_t>(i, c).data());
          } else {
            for (int k = 0; k < X; ++k) {
              const float raw = s.Sample(i, c, row + xs[size_t(k)]);
              char& g = good[size_t(k) * n + i];
              g = g && Usable(raw);
              y[size_t(k) * n + i] += w * raw;
              // The tone-curve candidates act on each channel's code value (in [0, 1]).
              yd[size_t(k) * n + i] += w * decode(raw);
              ye[size_t(k) * n + i] += w * encode(raw);
            }
          }
        }
      }
      for (int k = 0; k < X; ++k) {
        if (s.has_mask() && s.mask.data()[row + xs[size_t(k)]] < 0.5f) continue;
        collect.v.clear();
        for (int i = 0; i < n; ++i)
          if (good[size_t(k) * n + i] && y[size_t(k) * n + i] > 1e-3)
            collect.v.push_back({y[size_t(k) * n + i], i});
        if (near) {
          const Vec3 x = NearTexelPosition(s, xs[size_t(k)], ys[size_t(r)]);
          for (int i = 0; i < n; ++i) {
            const LightSample& l = s.lights()[size_t(i)];
            lvec[size_t(i)] = Normalize(l.position - x) * NearFalloff(l, x);
          }
        }
        collect.Add(s, yd.data() + size_t(k) * n, ye.data() + size_t(k) * n,
                    near ? lvec.data() : nullptr, &out);
      }
    }
  });
  if (s.is_band()) {
    const std::vector<std::string> bands = s.band.comm->AllGather(PackRows(texels));
    texels.clear();
    for (const std::string& b : bands) UnpackRows(b, &texels);
  }
  for (const SampledTexels& r : texels) d.texels_used += int(r.size());
  if (d.texels_used < 16) return d;
  d.residual_linear = LambertResidual(texels, 1.0);
  // Golden-section search on log γ over [0.3, 3.3] after a coarse scan.
  double best = 1.0, best_r = d.residual_linear;
  for (int k = 0; k <= 24; ++k) {
    const double g = 0.3 * std::pow(11.0, k / 24.0);
    const double r = LambertResidual(texels, g);
    if (r < best_r) best_r = r, best = g;
  }
  double a = std::log(best) - std::log(11.0) / 24, b = std::log(best) + std::log(11.0) / 24;
  const double phi = (std::sqrt(5.0) - 1) / 2;
  // One new residual per step: the kept interior point is the next step's other one.
  double x1 = b - phi * (b - a), x2 = a + phi * (b - a);
  double r1 = LambertResidual(texels, std::exp(x1)), r2 = LambertResidual(texels, std::exp(x2));
  for (int it = 0; it < 20; ++it) {
    if (r1 < r2) {
      b = x2, x2 = x1, r2 = r1;
      x1 = b - phi * (b - a), r1 = LambertResidual(texels, std::exp(x1));
    } else {
      a = x1, x1 = x2, r1 = r2;
      x2 = a + phi * (b - a), r2 = LambertResidual(texels, std::exp(x2));
    }
  }
  const double g = std::exp((a + b) / 2), r = LambertResidual(texels, g);
  if (r < best_r) best = g, best_r = r;
  d.encoding_exponent = best;
  d.residual_best = best_r;
  d.residual_srgb_decoded = LambertResidual(texels, 1.0, kSrgbDecoded);
  d.residual_srgb_encoded = LambertResidual(texels, 1.0, kSrgbEncoded);
  d.evidence = best_r > 0 ? d.residual_linear / best_r : 1.0;
  // The verdict: no better than the read → as read; else the sRGB form on γ̂'s side when its
  // residual is within 2× of γ̂'s (one fixed curve against a fitted exponent; the sRGB toe can fit
  // better than any power), else a power when γ̂ is interior to the search range.
  // A mistake must be one the reader can have made: values read as they are stored (linear)
  // cannot have been "decoded as sRGB", nor decoded ones "read as linear" (a stack without
  // recorded encodings, e.g. rendered in memory, may be either).
  bool read_linear = !s.encodings.empty(), read_decoded = !s.encodings.empty();
  for (const ColorEncoding& e : s.encodings) {
    const bool linear = e.transfer == TransferFunction::kLinear;
    read_linear = read_linear && linear, read_decoded = read_decoded && !linear;
  }
  const bool interior = best > 0.31 && best < 3.2;
  if (d.evidence < 1.25 || std::abs(best - 1) <= 0.1)
    d.verdict = ToneVerdict::kAsRead;
  else if (best > 1 && !read_decoded && d.residual_srgb_decoded <= 2 * best_r)
    d.verdict = ToneVerdict::kSrgbReadAsLinear;
  else if (best < 1 && !read_linear && d.residual_srgb_encoded <= 2 * best_r)
    d.verdict = ToneVerdict::kLinearReadAsSrgb;
  else if (interior)
    d.verdict = ToneVerdict::kPower;
  else
    d.verdict = ToneVerdict::kUnknown;
  d.looks_linear_read_as_srgb = d.verdict == ToneVerdict::kLinearReadAsSrgb;
  // Lights at one elevation see every texel at nearly one n·l per azimuth: a specular lobe bends
  // the values as a curve would (ResolveToneCurve does not act there), and the warning says so.
  const bool one_elevation = LitElevationRange(s.lights()).span() < kMinToneElevationSpanDeg;
  if (d.looks_linear_read_as_srgb) {
    char msg[480];
    std::snprintf(msg, sizeof msg,
                  "the images look linear but were decoded as sRGB: the read values grow like "
                  "(n·l)^(1/%.2f), an sRGB encode makes them linear in n·l (Lambertian residual "
                  "%.2g → %.2g); re-read them with --color-space linear%s",
                  best, d.residual_linear, d.residual_srgb_encoded,
                  one_elevation ? " — unless the material is glossy: with every light at one "
                                  "elevation a specular lobe bends the values the same way, so "
                                  "--color-space auto leaves the reading as it is"
                                : "");
    d.warnings.push_back(Warning(WarningCode::kLinearReadAsSrgb, msg));
  }
  // Only an interior minimum is evidence (at the ends of [0.3, 3.3] the search is inconclusive).
  d.looks_gamma_encoded =
      !read_decoded && best >= 1.6 && best <= 3.0 && best_r < 0.5 * d.residual_linear;
  if (d.looks_gamma_encoded) {
    char msg[320];
    std::snprintf(
        msg, sizeof msg,
        "the images look gamma-encoded but were read as linear: values grow like "
        "(n·l)^(1/%.2f), not n·l (Lambertian residual %.2g → %.2g); re-read them as "
        "sRGB (--color-space srgb) or linearise them; every texel is marked 'suspect data'",
        best, d.residual_linear, best_r);
    d.warnings.push_back(Warning(WarningCode::kGammaEncoded, msg));
  }
  return d;
}

ToneResolution ResolveToneCurve(LightStack* s, StackDiagnostics* diag) {
  ToneResolution r;
  r.before = *diag;
  if (s->is_float() || s->encodings.empty() || s->num_images() == 0) return r;
  r.from = s->encodings[0];
  r.from_reason = s->encoding_reasons.empty() ? "" : s->encoding_reasons[0];
  for (size_t i = 0; i < s->encodings.size(); ++i)
    if (s->encodings[i].transfer != r.from.transfer || s->encodings[i].gamma != r.from.gamma ||
        (i < s->encoding_reasons.size() && s->encoding_reasons[i] == "user override"))
      return r;
  if (LitElevationRange(s->lights()).span() < kMinToneElevationSpanDeg ||
      diag->evidence < kToneActEvidence)
    return r;
  const bool linear = r.from.transfer == TransferFunction::kLinear;
  const double g = diag->encoding_exponent;
  // The curve chosen must itself explain the same samples better than the read: its residual
  // against the read's, both on the first diagnosis's samples.
  double residual_to = 0;
  if (diag->verdict == ToneVerdict::kSrgbReadAsLinear && linear)
    r.to = {TransferFunction::kSrgb, 1.0f}, residual_to = diag->residual_srgb_decoded;
  else if (diag->verdict == ToneVerdict::kLinearReadAsSrgb && !linear)
    r.to = {}, residual_to = diag->residual_srgb_encoded;
  else if (diag->verdict == ToneVerdict::kPower && linear && diag->looks_gamma_encoded)
    r.to = {TransferFunction::kGamma, float(std::round(g * 100) / 100)},
    residual_to = diag->residual_best;
  else
    return r;
  if (!(residual_to * kToneSwitchGain <= diag->residual_linear)) return r;
  const std::vector<ColorEncoding> encodings = s->encodings;
  const std::vector<std::string> reasons = s->encoding_reasons;
  char why[200];
  std::snprintf(why, sizeof why, "tone-curve estimate (gamma %.2f, evidence %.2f; was %s: %s)", g,
                diag->evidence, r.from.ToString().c_str(), r.from_reason.c_str());
  s->Relinearise(r.to, why);
  StackDiagnostics after = DiagnoseStack(*s);
  // The re-read must not show a mistake of its own (the estimate then did not settle).
  if (!after.warnings.empty() || after.verdict == ToneVerdict::kSrgbReadAsLinear ||
      after.verdict == ToneVerdict::kLinearReadAsSrgb) {
    s->Relinearise(r.from, r.from_reason);
    s->encodings = encodings, s->encoding_reasons = reasons;
    r.to = r.from;
    return r;
  }
  r.corrected = true;
  const char* keep = linear ? "pass --color-space linear to keep the first reading"
                     : r.from.transfer == TransferFunction::kSrgb
                         ? "pass --color-space srgb to keep the first reading"
                         : "pass --color-space srgb or --color-space linear to choose yourself";
  char msg[440];
  std::snprintf(msg, sizeof msg,
                "the images were read as %s (%s), but their values grow like (n·l)^(1/%.2f); "
                "read as %s instead, they are linear in n·l (Lambertian residual %.2g → %.2g on "
                "the same samples; gamma now %.2f); %s",
                r.from.ToString().c_str(), r.from_reason.c_str(), g, r.to.ToString().c_str(),
                diag->residual_linear, residual_to, after.encoding_exponent, keep);
  after.warnings.insert(after.warnings.begin(), Warning(WarningCode::kToneCorrected, msg));
  *diag = std::move(after);
  return r;
}

const char* ToneVerdictName(ToneVerdict v) {
  switch (v) {
    case ToneVerdict::kAsRead: return "as-read";
    case ToneVerdict::kSrgbReadAsLinear: return "srgb-read-as-linear";
    case ToneVerdict::kLinearReadAsSrgb: return "linear-read-as-srgb";
    case ToneVerdict::kPower: return "power";
    case ToneVerdict::kUnknown: break;
  }
  return "unknown";
}

std::string DescribeToneCurve(const StackDiagnostics& d) {
  char buf[200];
  const char* what = "";
  switch (d.verdict) {
    case ToneVerdict::kAsRead:
      what = std::abs(d.encoding_exponent - 1) <= 0.1
                 ? "consistent with how the images were read"
                 : "no clear evidence against how the images were read";
      break;
    case ToneVerdict::kSrgbReadAsLinear: what = "sRGB-encoded images read as linear"; break;
    case ToneVerdict::kLinearReadAsSrgb: what = "linear images decoded as sRGB"; break;
    case ToneVerdict::kPower: what = "a power curve neither linear nor sRGB"; break;
    case ToneVerdict::kUnknown: what = "inconclusive"; break;
  }
  if (d.texels_used < 16) return "not estimated (too few usable texels or lights)";
  std::snprintf(buf, sizeof buf, "gamma %.2f (evidence %.2f, %d texels): %s", d.encoding_exponent,
                d.evidence, d.texels_used, what);
  return buf;
}

}  // namespace matfit::fit
