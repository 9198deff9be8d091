// Relighting bases fitted like Lambert: `ptm` (6 polynomial terms) and `hsh2`/`hsh3`
// (hemispherical harmonics, 4 / 9 terms). The N × k basis matrix B is the same for every texel,
// so one pseudo-inverse (B⁺, k × N) serves all of them: coefficients = B⁺ · p per channel.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <vector>

#include "core/shading/relight_basis.h"
#include "fit/fit_common.h"
#include "fit/methods.h"

namespace matfit::fit {
namespace {

using BasisFn = std::function<void(const Vec3&, double*)>;

StatusOr<FitResult> FitLinearBasis(const LightStack& s, const FitOptions& o,
                                   const std::string& name, ShadingModel model, int K,
                                   const BasisFn& basis) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const int n = s.num_images(), C = s.channels(), W = s.width();
  if (n < K)
    return InvalidArgument(name + ": " + std::to_string(n) + " light(s) for " + std::to_string(K) +
                           " coefficients per channel; capture at least " + std::to_string(K) +
                           " light directions or use a smaller basis");
  Eigen::MatrixXd B(n, K);
  for (int i = 0; i < n; ++i) {
    double b[shading::kMaxHshTerms];
    basis(s.lights()[i].direction, b);
    for (int j = 0; j < K; ++j) B(i, j) = b[j];
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(B, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto sv = svd.singularValues();
  if (!(sv[K - 1] > 1e-6 * sv[0]))
    return InvalidArgument(name + ": the light directions do not determine the " +
                           std::to_string(K) + " basis terms (basis matrix rank < " +
                           std::to_string(K) +
                           ", e.g. every light at one elevation); use lights at several θ or the "
                           "lambert model");
  const Eigen::MatrixXd P = svd.solve(Eigen::MatrixXd::Identity(n, n));  // K × n
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, model, name, &r);
  MarkUnfittableTexels(s, /*flag_clipped=*/true, &r);
  r.maps.coefficients = Image(s.width(), s.height(), K * C);
  r.maps.basis_terms = K;
  r.parameters["basis_condition_number"] = sv[0] / sv[K - 1];
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<float> pinv(size_t(K) * n);
  for (int j = 0; j < K; ++j)
    for (int i = 0; i < n; ++i) pinv[size_t(j) * n + i] = float(P(j, i));
  // The frontal-light value of the basis, as a preview albedo.
  double front[shading::kMaxHshTerms];
  basis(Vec3(0, 0, 1), front);

  const bool ok = ForEachTile(s, o, [&](const Tile& t) {
    std::vector<float> acc(size_t(K) * t.width);
    for (int y = t.y0; y < t.y0 + t.height; ++y) {
      const int64_t row = int64_t(y) * W + t.x0;
      for (int c = 0; c < C; ++c) {
        std::fill(acc.begin(), acc.end(), 0.0f);
        for (int i = 0; i < n; ++i) {
          const float* src = s.Plane(i, c).data() + row;
          const float w = inv[i * C + c];
          for (int j = 0; j < K; ++j) {
            const float pj = pinv[size_t(j) * n + i] * w;
            float* a = acc.data() + size_t(j) * t.width;
            for (int k = 0; k < t.width; ++k) a[k] += pj * src[k];
          }
        }
        for (int j = 0; j < K; ++j)
          std::copy_n(acc.data() + size_t(j) * t.width, t.width,
                      r.maps.coefficients.Plane(c * K + j).data() + row);
      }
      for (int k = 0; k < t.width; ++k) {
        const int64_t p = row + k;
        if (r.status[p] != kTexelOk) {  // masked or clipped: no coefficients
          for (int q = 0; q < K * C; ++q) r.maps.coefficients.Plane(q)[p] = 0.0f;
          continue;
        }
        bool finite = true;
        for (int q = 0; q < K * C; ++q) finite &= std::isfinite(r.maps.coefficients.Plane(q)[p]);
        if (!finite) r.status[p] = kTexelNonFinite;
        for (int c = 0; c < 3; ++c) {
          double v = 0;
          for (int j = 0; j < K; ++j)
            v += front[j] * r.maps.coefficients.Plane((C == 1 ? 0 : c) * K + j)[p];
          r.maps.albedo.Plane(c)[p] = float(v);
        }
        r.maps.normal.Plane(2)[p] = 1.0f;
      }
    }
  });
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace

StatusOr<FitResult> FitPtm(const LightStack& s, const FitOptions& o) {
  return FitLinearBasis(s, o, "ptm", ShadingModel::kPtm, shading::kPtmTerms,
                        [](const Vec3& l, double* b) { shading::PtmBasis(l, b); });
}

StatusOr<FitResult> FitHsh(const LightStack& s, const FitOptions& o, int order) {
  if (order < 1 || order > 4)
    return InvalidArgument("hsh order must be 1 to 4, got " + std::to_string(order));
  return FitLinearBasis(s, o, "hsh" + std::to_string(order), ShadingModel::kHsh, order * order,
                        [order](const Vec3& l, double* b) { shading::HshBasis(order, l, b); });
}

}  // namespace matfit::fit
