#include "core/pack/ptm_export.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

#include "core/model/model.h"

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

// One scale and bias per term over the values value(s, j), s < count.
struct Quantiser {
  std::array<double, kTerms> scale{};
  std::array<int, kTerms> bias{};

  template <typename Value>
  Quantiser(int64_t count, const Value& value) {
    std::array<double, kTerms> lo{}, hi{};  // the range includes 0: the bias is a code in [0, 255]
    for (int64_t s = 0; s < count; ++s)
      for (int j = 0; j < kTerms; ++j) {
        const double v = value(s, j);
        lo[size_t(j)] = std::min(lo[size_t(j)], v), hi[size_t(j)] = std::max(hi[size_t(j)], v);
      }
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
    char* o = out.data() + head;
    for (int c = 0; c < 3; ++c)
      for (int64_t k = 0; k < n; ++k) {
        const int64_t p = file_texel(k);
        for (int j = 0; j < kTerms; ++j) *o++ = char(q.Code(j, a(c, p, j)));
      }
    return out;
  }
  // LRGB: per texel, the common polynomial L (channel mean) and gains k_c = <a_c, L> / <L, L>,
  // rescaled so that the largest gain is at most 1 (a colour byte).
  std::vector<double> lum(size_t(n * kTerms));
  std::vector<std::array<double, 3>> gain(static_cast<size_t>(n));
  for (int64_t p = 0; p < n; ++p) {
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
  const Quantiser q(n, [&](int64_t s, int j) { return lum[size_t(s * kTerms + j)]; });
  std::string out = Header("PTM_FORMAT_LRGB", W, H, q);
  out.reserve(out.size() + size_t(n * (kTerms + 3)));
  for (int64_t k = 0; k < n; ++k) {
    const double* L = &lum[size_t(file_texel(k) * kTerms)];
    for (int j = 0; j < kTerms; ++j) out.push_back(char(q.Code(j, L[j])));
  }
  for (int64_t k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c) out.push_back(char(ByteOf(255 * gain[size_t(file_texel(k))][c])));
  return out;
}

}  // namespace matfit
