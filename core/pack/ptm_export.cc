#include "core/pack/ptm_export.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <vector>

namespace matfit {
namespace {

constexpr int kTerms = 6;

// One scale and bias per term over `values` (term j of sample s at values[s * 6 + j]).
struct Quantiser {
  std::array<double, kTerms> scale{};
  std::array<int, kTerms> bias{};

  explicit Quantiser(const std::vector<double>& values) {
    for (int j = 0; j < kTerms; ++j) {
      double lo = 0, hi = 0;  // the range includes 0: the bias is a code in [0, 255]
      for (size_t s = j; s < values.size(); s += kTerms)
        lo = std::min(lo, values[s]), hi = std::max(hi, values[s]);
      scale[j] = hi > lo ? (hi - lo) / 255.0 : 1e-6;
      bias[j] = int(std::clamp(std::lround(-lo / scale[j]), 0L, 255L));
    }
  }
  unsigned char Code(int j, double a) const {
    return static_cast<unsigned char>(std::clamp(std::lround(a / scale[j] + bias[j]), 0L, 255L));
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
  if (m.model != ShadingModel::kPtm || m.basis_terms != kTerms || (ch != 1 && ch != 3) ||
      m.coefficients.channels() != ch * kTerms || m.coefficients.width() != m.width ||
      m.coefficients.height() != m.height)
    return InvalidArgument("a .ptm file holds a 6-term ptm fit of 1 or 3 channels");
  const int W = m.width, H = m.height;
  const int64_t n = int64_t(W) * H;
  // a[(c * n + p) * 6 + j]: term j of channel c at texel p, in code units (× 255).
  std::vector<double> a(size_t(3 * n * kTerms));
  for (int c = 0; c < 3; ++c)
    for (int j = 0; j < kTerms; ++j) {
      const auto plane = m.coefficients.Plane((ch == 3 ? c : 0) * kTerms + j);
      for (int64_t p = 0; p < n; ++p) {
        const double v = plane[p];
        a[size_t((c * n + p) * kTerms + j)] = std::isfinite(v) ? 255.0 * v : 0.0;
      }
    }
  // Texels in file order: the bottom row first.
  auto file_texel = [&](int64_t k) { return int64_t(H - 1 - k / W) * W + k % W; };
  if (format == PtmFormat::kRgb) {
    const Quantiser q(a);
    std::string out = Header("PTM_FORMAT_RGB", W, H, q);
    out.reserve(out.size() + size_t(3 * n * kTerms));
    for (int c = 0; c < 3; ++c)
      for (int64_t k = 0; k < n; ++k) {
        const double* t = &a[size_t((c * n + file_texel(k)) * kTerms)];
        for (int j = 0; j < kTerms; ++j) out.push_back(char(q.Code(j, t[j])));
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
      for (int c = 0; c < 3; ++c) L[j] += a[size_t((c * n + p) * kTerms + j)] / 3;
      ll += L[j] * L[j];
    }
    double kmax = 0;
    for (int c = 0; c < 3; ++c) {
      double al = 0;
      for (int j = 0; j < kTerms; ++j) al += a[size_t((c * n + p) * kTerms + j)] * L[j];
      gain[size_t(p)][c] = ll > 0 ? std::max(0.0, al / ll) : 0.0;
      kmax = std::max(kmax, gain[size_t(p)][c]);
    }
    if (kmax > 1) {
      for (int j = 0; j < kTerms; ++j) L[j] *= kmax;
      for (int c = 0; c < 3; ++c) gain[size_t(p)][c] /= kmax;
    }
  }
  const Quantiser q(lum);
  std::string out = Header("PTM_FORMAT_LRGB", W, H, q);
  out.reserve(out.size() + size_t(n * (kTerms + 3)));
  for (int64_t k = 0; k < n; ++k) {
    const double* L = &lum[size_t(file_texel(k) * kTerms)];
    for (int j = 0; j < kTerms; ++j) out.push_back(char(q.Code(j, L[j])));
  }
  for (int64_t k = 0; k < n; ++k)
    for (int c = 0; c < 3; ++c)
      out.push_back(char(std::clamp(std::lround(255 * gain[size_t(file_texel(k))][c]), 0L, 255L)));
  return out;
}

}  // namespace matfit
