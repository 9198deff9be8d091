#include "core/pack/ptm_export.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <memory>
#include <mutex>
#include <vector>

#include "core/model/model.h"
#include "core/parallel.h"

namespace matfit {
namespace {

constexpr int kTerms = 6;

// lround(x) clamped to [0, 255], without the libm call: for x ≥ 0 the same integer (ties away
// from zero), and every x < 0.5 gives 0 either way.
inline unsigned char ByteOf(double x) {
  if (!(x >= 0.5)) return 0;
  if (x >= 255) return 255;
  const double f = std::floor(x);
  return static_cast<unsigned char>(int(f) + (x - f >= 0.5));
}

// Texels per ParallelFor range of the encoders (every byte depends on its texel alone, and the
// ranges' minima and maxima merge in any order: the file is the same on any thread count).
constexpr int64_t kGrain = 16384;

// One scale and bias per term over the values value(s, j), s < count.
struct Quantiser {
  std::array<double, kTerms> scale{};
  std::array<int, kTerms> bias{};

  template <typename Value>
  Quantiser(int64_t count, const Value& value) {
    std::array<double, kTerms> lo{}, hi{};  // the range includes 0: the bias is a code in [0, 255]
    std::mutex merge;
    ParallelFor(
        0, count,
        [&](int64_t s0, int64_t s1) {
          std::array<double, kTerms> l{}, h{};
          for (int64_t s = s0; s < s1; ++s)
            for (int j = 0; j < kTerms; ++j) {
              const double v = value(s, j);
              l[size_t(j)] = std::min(l[size_t(j)], v), h[size_t(j)] = std::max(h[size_t(j)], v);
            }
          std::lock_guard<std::mutex> lock(merge);
          for (size_t j = 0; j < size_t(kTerms); ++j)
            lo[j] = std::min(lo[j], l[j]), hi[j] = std::max(hi[j], h[j]);
        },
        kGrain);
    for (int j = 0; j < kTerms; ++j) {
      scale[size_t(j)] =
          hi[size_t(j)] > lo[size_t(j)] ? (hi[size_t(j)] - lo[size_t(j)]) / 255.0 : 1e-6;
      bias[size_t(j)] = int(std::clamp(std::lround(-lo[size_t(j)] / scale[size_t(j)]), 0L, 255L));
    }
  }
  unsigned char Code(int j, double a) const {
    return ByteOf(a / scale[size_t(j)] + bias[size_t(j)]);
  }
};

std::string Header(const char* format, int w, int h, const Quantiser& q) {
  std::string out = std::string("PTM_1.2\n") + format + "\n" + std::to_string(w) + "\n" +
                    std::to_string(h) + "\n";
  char buf[40];
  for (int j = 0; j < kTerms; ++j) {
    std::snprintf(buf, sizeof buf, "%.9g", q.scale[j]);
    out += (j ? " " : "") + std::string(buf);
  }
  out += "\n";
  for (int j = 0; j < kTerms; ++j) out += (j ? " " : "") + std::to_string(q.bias[j]);
  return out + "\n";
}

}  // namespace

StatusOr<std::string> EncodePtm(const MaterialMaps& m, PtmFormat format) {
  const int ch = m.basis_terms == kTerms ? m.coefficients.channels() / kTerms : 0;
  if (!HasRtiBasis(m.model, "ptm") || m.basis_terms != kTerms || (ch != 1 && ch != 3) ||
      m.coefficients.channels() != ch * kTerms || m.coefficients.width() != m.width ||
      m.coefficients.height() != m.height)
    return InvalidArgument("a .ptm file holds a 6-term ptm fit of 1 or 3 channels");
  const int W = m.width, H = m.height;
  const int64_t n = int64_t(W) * H;
  // Term j of channel c at texel p in code units (× 255); a non-finite coefficient is 0.
  const float* planes[3][kTerms];
  for (int c = 0; c < 3; ++c)
    for (int j = 0; j < kTerms; ++j)
      planes[c][j] = m.coefficients.Plane((ch == 3 ? c : 0) * kTerms + j).data();
  auto a = [&](int c, int64_t p, int j) {
    const double v = planes[c][j][p];
    return std::isfinite(v) ? 255.0 * v : 0.0;
  };
  // Texels in file order: the bottom row first.
  auto file_texel = [&](int64_t k) { return int64_t(H - 1 - k / W) * W + k % W; };
  if (format == PtmFormat::kRgb) {
    const Quantiser q(3 * n, [&](int64_t s, int j) { return a(int(s / n), s % n, j); });
    std::string out = Header("PTM_FORMAT_RGB", W, H, q);
    const size_t head = out.size();
    out.resize(head + size_t(3 * n * kTerms));
    char* const o = out.data() + head;  // channel c's term j of file texel k at (c n + k) 6 + j
    ParallelFor(
        0, 3 * n,
        [&](int64_t s0, int64_t s1) {
          for (int64_t s = s0; s < s1; ++s) {
            const int c = int(s / n);
            const int64_t p = file_texel(s % n);
            for (int j = 0; j < kTerms; ++j) o[s * kTerms + j] = char(q.Code(j, a(c, p, j)));
          }
        },
        kGrain);
    return out;
  }
  // LRGB: per texel, the common polynomial L (channel mean) and gains k_c = <a_c, L> / <L, L>,
  // rescaled so that the largest gain is at most 1 (a colour byte).
  // Written in full below, by the threads that read them next: not zero-filled first.
  const auto lum = std::make_unique_for_overwrite<double[]>(size_t(n * kTerms));
  const auto gain = std::make_unique_for_overwrite<std::array<double, 3>[]>(size_t(n));
  ParallelFor(
      0, n,
      [&](int64_t p0, int64_t p1) {
        for (int64_t p = p0; p < p1; ++p) {
          double* L = &lum[size_t(p * kTerms)];
          double ll = 0;
          for (int j = 0; j < kTerms; ++j) {
            L[j] = 0;
            for (int c = 0; c < 3; ++c) L[j] += a(c, p, j) / 3;
            ll += L[j] * L[j];
          }
          double kmax = 0;
          for (int c = 0; c < 3; ++c) {
            double al = 0;
            for (int j = 0; j < kTerms; ++j) al += a(c, p, j) * L[j];
            gain[size_t(p)][c] = ll > 0 ? std::max(0.0, al / ll) : 0.0;
            kmax = std::max(kmax, gain[size_t(p)][c]);
          }
          if (kmax > 1) {
            for (int j = 0; j < kTerms; ++j) L[j] *= kmax;
            for (int c = 0; c < 3; ++c) gain[size_t(p)][c] /= kmax;
          }
        }
      },
      kGrain);
  const Quantiser q(n, [&](int64_t s, int j) { return lum[size_t(s * kTerms + j)]; });
  std::string out = Header("PTM_FORMAT_LRGB", W, H, q);
  const size_t head = out.size();
  out.resize(head + size_t(n * (kTerms + 3)));
  char* const o = out.data() + head;  // every texel's 6 terms, then every texel's 3 gains
  ParallelFor(
      0, n,
      [&](int64_t k0, int64_t k1) {
        for (int64_t k = k0; k < k1; ++k) {
          const int64_t p = file_texel(k);
          const double* L = &lum[size_t(p * kTerms)];
          for (int j = 0; j < kTerms; ++j) o[k * kTerms + j] = char(q.Code(j, L[j]));
          for (int c = 0; c < 3; ++c)
            o[n * kTerms + k * 3 + c] = char(ByteOf(255 * gain[size_t(p)][size_t(c)]));
        }
      },
      kGrain);
  return out;
}

}  // namespace matfit
