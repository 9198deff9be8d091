#include "core/pack/rti_export.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <mutex>
#include <numbers>
#include <vector>

#include "core/model/model.h"
#include "core/parallel.h"
#include "core/shading/relight_basis.h"

namespace matfit {

void RtiHshBasis(int terms, double lx, double ly, double lz, double* w) {
  const double pi = std::numbers::pi;
  const double c = std::clamp(lz, 0.0, 1.0), phi = std::atan2(ly, lx);
  const double s = std::sqrt(std::max(0.0, c - c * c));
  w[0] = 1 / std::sqrt(2 * pi);
  if (terms < 4) return;
  w[1] = std::sqrt(6 / pi) * std::cos(phi) * s;
  w[2] = std::sqrt(3 / (2 * pi)) * (2 * c - 1);
  w[3] = std::sqrt(6 / pi) * std::sin(phi) * s;
  if (terms < 9) return;
  w[4] = std::sqrt(30 / pi) * std::cos(2 * phi) * (c * c - c);
  w[5] = std::sqrt(30 / pi) * std::cos(phi) * (2 * c - 1) * s;
  w[6] = std::sqrt(5 / (2 * pi)) * (1 - 6 * c + 6 * c * c);
  w[7] = std::sqrt(30 / pi) * std::sin(phi) * (2 * c - 1) * s;
  w[8] = std::sqrt(30 / pi) * std::sin(2 * phi) * (c * c - c);
}

Status RtiHshTermMap(int terms, int* from, double* sign) {
  if (terms != 4 && terms != 9) return InvalidArgument("RTI HSH has 4 or 9 terms");
  const int order = terms == 4 ? 2 : 3;
  // RTI term i is matfit term l² + l + m for RTI's l² + l − m, times a sign found where no term
  // vanishes (the two bases agree there up to that sign, which the check below confirms).
  const Vec3 l = Normalize(Vec3{0.31, 0.47, 0.83});
  double mine[shading::kMaxHshTerms], rti[9];
  shading::HshBasis(order, l, mine);
  RtiHshBasis(terms, l.x, l.y, l.z, rti);
  for (int band = 0; band * band < terms; ++band)
    for (int mm = -band; mm <= band; ++mm) {
      const int i = band * band + band - mm, j = band * band + band + mm;
      from[i] = j;
      sign[i] = mine[j] * rti[i] > 0 ? 1.0 : -1.0;
      if (std::abs(std::abs(mine[j]) - std::abs(rti[i])) > 1e-9 * (1 + std::abs(rti[i])))
        return Status(StatusCode::kInternal,
                      "the RTI HSH basis and matfit's differ in term " + std::to_string(i));
    }
  return Status::Ok();
}

StatusOr<std::string> EncodeRti(const MaterialMaps& m) {
  const int terms = m.basis_terms;
  const int ch = terms > 0 ? m.coefficients.channels() / terms : 0;
  if (!HasRtiBasis(m.model, "hsh") || (terms != 4 && terms != 9) || (ch != 1 && ch != 3) ||
      m.coefficients.channels() != ch * terms || m.coefficients.width() != m.width ||
      m.coefficients.height() != m.height)
    return InvalidArgument("an .rti file holds an hsh fit of 4 or 9 terms and 1 or 3 channels");
  int from[9];
  double sign[9];
  MATFIT_RETURN_IF_ERROR(RtiHshTermMap(terms, from, sign));
  const int W = m.width, H = m.height;
  const int64_t n = int64_t(W) * H;
  auto coef = [&](int64_t p, int band, int i) {
    const double v = m.coefficients.Plane((ch == 3 ? band : 0) * terms + from[i])[p];
    return std::isfinite(v) ? sign[i] * v : 0.0;
  };
  // Per term: bias = the smallest coefficient, scale = the range (bytes 0 … 255 span it).
  std::vector<float> scale(static_cast<size_t>(terms)), bias(static_cast<size_t>(terms));
  // Ranges of texels in parallel (minima and maxima merge in any order: the same file on any
  // thread count).
  constexpr int64_t kGrain = 16384;
  double lo[9], hi[9];
  std::fill_n(lo, 9, 1e300), std::fill_n(hi, 9, -1e300);
  std::mutex merge;
  ParallelFor(
      0, n,
      [&](int64_t p0, int64_t p1) {
        double l[9], h[9];
        std::fill_n(l, 9, 1e300), std::fill_n(h, 9, -1e300);
        for (int64_t p = p0; p < p1; ++p)
          for (int i = 0; i < terms; ++i)
            for (int b = 0; b < 3; ++b)
              l[i] = std::min(l[i], coef(p, b, i)), h[i] = std::max(h[i], coef(p, b, i));
        std::lock_guard<std::mutex> lock(merge);
        for (int i = 0; i < terms; ++i)
          lo[i] = std::min(lo[i], l[i]), hi[i] = std::max(hi[i], h[i]);
      },
      kGrain);
  for (int i = 0; i < terms; ++i) {
    if (n == 0) lo[i] = hi[i] = 0;
    bias[size_t(i)] = float(lo[i] + 0.0);  // −0 and +0 merge in any order: always write +0
    scale[size_t(i)] = hi[i] > lo[i] ? float(hi[i] - lo[i]) : 1e-6f;
  }
  std::string out = "#HSH1.2\n#written by matfit\n3\n" + std::to_string(W) + " " +
                    std::to_string(H) + " 3\n" + std::to_string(terms) + " 2 1\n";
  const size_t header = out.size();
  out.resize(header + 8 * size_t(terms));
  static_assert(sizeof(float) == 4, "float32");
  std::memcpy(&out[header], scale.data(), 4 * size_t(terms));  // little-endian hosts only
  std::memcpy(&out[header + 4 * size_t(terms)], bias.data(), 4 * size_t(terms));
  const size_t head = out.size();
  out.resize(head + size_t(n) * 3 * size_t(terms));
  char* const o = out.data() + head;  // file texel k's band b, term i at (3 k + b) terms + i
  ParallelFor(
      0, n,
      [&](int64_t k0, int64_t k1) {
        for (int64_t k = k0; k < k1; ++k) {
          const int64_t p = int64_t(H - 1 - k / W) * W + k % W;  // the bottom row first
          for (int b = 0; b < 3; ++b)
            for (int i = 0; i < terms; ++i) {
              // The float32 scale and bias are what a reader has: quantise against those.
              const long code = std::lround((coef(p, b, i) - double(bias[size_t(i)])) /
                                            double(scale[size_t(i)]) * 255.0);
              o[(3 * k + b) * terms + i] = char(std::clamp(code, 0L, 255L));
            }
        }
      },
      kGrain);
  return out;
}

}  // namespace matfit
