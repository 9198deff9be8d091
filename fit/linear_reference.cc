// Literal per-texel references for the linear fits (what the fast one-pass forms are measured
// against): for every texel build the normal equations AᵀA x = Aᵀb from its samples and solve
// them by Gauss–Jordan, with no sharing across texels. Slow by design; same outputs as the fast
// forms up to float rounding.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "core/shading/relight_basis.h"
#include "fit/fit_common.h"
#include "fit/gauss_jordan.h"
#include "fit/methods.h"

namespace matfit::fit {

StatusOr<FitResult> FitLambertReference(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  if (s.num_images() < 3)
    return InvalidArgument("lambert-reference: needs at least 3 lights, got " +
                           std::to_string(s.num_images()));
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, "lambert", "lambert-reference", &r);
  MarkUnfittableTexels(s, /*flag_clipped=*/true, &r);
  const std::vector<float> inv = InverseIntensities(s);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    std::vector<double> q(size_t(n) * C);
    for (int y = t.y0; y < t.y0 + t.height; ++y)
      for (int x = t.x0; x < t.x0 + t.width; ++x) {
        const int64_t p = int64_t(y) * W + x;
        if (r.status[p] != kTexelOk) continue;
        double ata[9] = {}, atb[3] = {};
        for (int i = 0; i < n; ++i) {
          double lum = 0;
          for (int c = 0; c < C; ++c) {
            q[i * C + c] = double(s.Sample(i, c, p)) * inv[i * C + c];
            lum += (C == 1 ? 1.0 : double(kLuma[c])) * q[i * C + c];
          }
          const Vec3& l = s.lights()[i].direction;
          for (int a = 0; a < 3; ++a) {
            atb[a] += l[a] * lum;
            for (int b = 0; b < 3; ++b) ata[a * 3 + b] += l[a] * l[b];
          }
        }
        if (!std::isfinite(atb[0] + atb[1] + atb[2])) {
          r.status[p] = kTexelNonFinite;
          continue;
        }
        if (!GaussJordanSolve<3>(ata, atb)) {
          r.status[p] = kTexelIllConditioned;
          continue;
        }
        const Vec3 g(atb[0], atb[1], atb[2]);
        if (!(Length(g) > 1e-6)) {
          r.status[p] = kTexelNoSignal;
          continue;
        }
        const Vec3 u = g / Length(g);
        double num[3] = {}, den = 0;
        for (int i = 0; i < n; ++i) {
          const double d = Dot(u, s.lights()[i].direction);
          den += d * d;
          for (int c = 0; c < C; ++c) num[c] += q[i * C + c] * d;
        }
        for (int c = 0; c < 3; ++c) {
          r.maps.normal.Plane(c)[p] = float(u[c]);
          r.maps.albedo.Plane(c)[p] = float(num[C == 1 ? 0 : c] / den);
        }
      }
  });
  return FinishFit(ok, t0, std::move(r));
}

namespace {

// Per texel and channel: AᵀA (K × K) and Aᵀp from the basis rows b_i (the design matrix is
// computed once; the normal equations are built and solved per texel, as a literal fit does).
template <int K>
void SolveBasisTexels(const LightStack& s, const std::vector<double>& rows,
                      const std::vector<float>& inv, const double* front, const Tile& t,
                      FitResult* r) {
  const int n = s.num_images(), C = s.channels(), W = s.width();
  for (int y = t.y0; y < t.y0 + t.height; ++y)
    for (int x = t.x0; x < t.x0 + t.width; ++x) {
      const int64_t p = int64_t(y) * W + x;
      if (r->status[p] != kTexelOk) continue;
      for (int c = 0; c < C && r->status[p] == kTexelOk; ++c) {
        double ata[K * K] = {}, atb[K] = {};
        for (int i = 0; i < n; ++i) {
          const double* b = rows.data() + size_t(i) * K;
          const double v = double(s.Sample(i, c, p)) * inv[i * C + c];
          for (int j = 0; j < K; ++j) {
            atb[j] += b[j] * v;
            for (int k = 0; k < K; ++k) ata[j * K + k] += b[j] * b[k];
          }
        }
        double sum = 0;
        for (int j = 0; j < K; ++j) sum += atb[j];
        if (!std::isfinite(sum))
          r->status[p] = kTexelNonFinite;
        else if (!GaussJordanSolve<K>(ata, atb))
          r->status[p] = kTexelIllConditioned;
        else
          for (int j = 0; j < K; ++j) r->maps.coefficients.Plane(c * K + j)[p] = float(atb[j]);
      }
      if (r->status[p] != kTexelOk) {
        for (int q = 0; q < K * C; ++q) r->maps.coefficients.Plane(q)[p] = 0.0f;
        continue;
      }
      for (int c = 0; c < 3; ++c) {
        double v = 0;
        for (int j = 0; j < K; ++j)
          v += front[j] * r->maps.coefficients.Plane((C == 1 ? 0 : c) * K + j)[p];
        r->maps.albedo.Plane(c)[p] = float(v);
      }
      r->maps.normal.Plane(2)[p] = 1.0f;
    }
}

StatusOr<FitResult> FitBasisReference(const LightStack& s, const FitOptions& o,
                                      const std::string& name, std::string_view model, int K,
                                      void (*basis)(int, const Vec3&, double*), int order) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const int n = s.num_images(), C = s.channels();
  if (n < K)
    return InvalidArgument(name + ": " + std::to_string(n) + " light(s) for " + std::to_string(K) +
                           " coefficients per channel");
  if (K != 4 && K != 6 && K != 9 && K != 16)
    return InvalidArgument(name + ": no reference for " + std::to_string(K) + " terms");
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, model, name, &r);
  MarkUnfittableTexels(s, /*flag_clipped=*/true, &r);
  r.maps.coefficients = Image(s.width(), s.height(), K * C);
  r.maps.basis_terms = K;
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<double> rows(size_t(n) * K);
  for (int i = 0; i < n; ++i) {
    double b[shading::kMaxHshTerms];
    basis(order, s.lights()[i].direction, b);
    std::copy_n(b, K, rows.data() + size_t(i) * K);
  }
  double front[shading::kMaxHshTerms];
  basis(order, Vec3(0, 0, 1), front);
  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    switch (K) {
      case 4: return SolveBasisTexels<4>(s, rows, inv, front, t, &r);
      case 6: return SolveBasisTexels<6>(s, rows, inv, front, t, &r);
      case 9: return SolveBasisTexels<9>(s, rows, inv, front, t, &r);
      default: return SolveBasisTexels<16>(s, rows, inv, front, t, &r);
    }
  });
  return FinishFit(ok, t0, std::move(r));
}

void PtmBasisOf(int, const Vec3& l, double* b) { shading::PtmBasis(l, b); }
void HshBasisOf(int order, const Vec3& l, double* b) { shading::HshBasis(order, l, b); }

}  // namespace

StatusOr<FitResult> FitPtmReference(const LightStack& s, const FitOptions& o) {
  return FitBasisReference(s, o, "ptm-reference", "ptm", shading::kPtmTerms, PtmBasisOf, 0);
}

StatusOr<FitResult> FitHshReference(const LightStack& s, const FitOptions& o, int order) {
  if (order < 1 || order > 4)
    return InvalidArgument("hsh order must be 1 to 4, got " + std::to_string(order));
  return FitBasisReference(s, o, "hsh" + std::to_string(order) + "-reference", "hsh", order * order,
                           HshBasisOf, order);
}

}  // namespace matfit::fit
