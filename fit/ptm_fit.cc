// `ptm`: polynomial texture maps (METHODS.md §4), 6 coefficients per channel, fitted by one
// precomputed pseudo-inverse of the N × 6 basis matrix for all texels.
#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <vector>

#include "core/shading/shading.h"
#include "fit/fit_common.h"
#include "fit/methods.h"

namespace matfit::fit {

StatusOr<FitResult> FitPtm(const LightStack& s, const FitOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  constexpr int K = shading::kPtmTerms;
  const int n = s.num_images(), C = s.channels(), W = s.width();
  if (n < K)
    return InvalidArgument("ptm: " + std::to_string(n) + " light(s) for " + std::to_string(K) +
                           " coefficients per channel; capture at least 6 light directions");
  Eigen::MatrixXd B(n, K);
  for (int i = 0; i < n; ++i) {
    double b[K];
    shading::PtmBasis(s.lights()[i].direction, b);
    for (int j = 0; j < K; ++j) B(i, j) = b[j];
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(B, Eigen::ComputeThinU | Eigen::ComputeThinV);
  const auto sv = svd.singularValues();
  if (!(sv[K - 1] > 1e-6 * sv[0]))
    return InvalidArgument(
        "ptm: the light directions do not determine the 6 polynomial terms "
        "(basis matrix rank < 6, e.g. every light at one elevation makes u² + v² "
        "constant); use lights at several θ or the lambert model");
  const Eigen::MatrixXd P = svd.solve(Eigen::MatrixXd::Identity(n, n));  // K × n
  const auto t0 = std::chrono::steady_clock::now();
  FitResult r;
  InitResult(s, ShadingModel::kPtm, "ptm", &r);
  r.maps.coefficients = Image(s.width(), s.height(), K * C);
  r.parameters["basis_condition_number"] = sv[0] / sv[K - 1];
  const std::vector<float> inv = InverseIntensities(s);
  std::vector<float> pinv(size_t(K) * n);
  for (int j = 0; j < K; ++j)
    for (int i = 0; i < n; ++i) pinv[size_t(j) * n + i] = float(P(j, i));

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
        if (r.status[p] == kTexelMasked) continue;
        bool finite = true;
        for (int q = 0; q < K * C; ++q) finite &= std::isfinite(r.maps.coefficients.Plane(q)[p]);
        if (!finite) r.status[p] = kTexelNonFinite;
        // Albedo map: the frontal-light value a5 (u = v = 0), a preview of the texture.
        for (int c = 0; c < 3; ++c)
          r.maps.albedo.Plane(c)[p] = r.maps.coefficients.Plane((C == 1 ? 0 : c) * K + K - 1)[p];
        r.maps.normal.Plane(2)[p] = 1.0f;
      }
    }
  });
  return FinishFit(ok, t0, std::move(r));
}

}  // namespace matfit::fit
