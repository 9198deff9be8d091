#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "core/shading/relight_basis.h"
#include "core/synth/light_sets.h"
#include "core/synth/random.h"
#include "core/synth/render_stack.h"
#include "fit/methods.h"
#include "fit/metrics.h"

namespace matfit::fit {
namespace {

TEST(Hsh, BasisIsOrthonormalOnTheHemisphere) {
  constexpr int kOrder = 4, K = kOrder * kOrder;
  double gram[K][K] = {};
  // Midpoint rule in (cos θ, φ): dω = d(cos θ) dφ.
  const int nz = 400, nphi = 400;
  const double dz = 1.0 / nz, dphi = 2 * std::numbers::pi / nphi;
  for (int a = 0; a < nz; ++a)
    for (int b = 0; b < nphi; ++b) {
      const double z = (a + 0.5) * dz, phi = (b + 0.5) * dphi, r = std::sqrt(1 - z * z);
      double h[shading::kMaxHshTerms];
      shading::HshBasis(kOrder, Vec3(r * std::cos(phi), r * std::sin(phi), z), h);
      for (int i = 0; i < K; ++i)
        for (int j = 0; j < K; ++j) gram[i][j] += h[i] * h[j] * dz * dphi;
    }
  for (int i = 0; i < K; ++i)
    for (int j = 0; j < K; ++j) EXPECT_NEAR(gram[i][j], i == j ? 1.0 : 0.0, 2e-4) << i << "," << j;
}

MaterialMaps RandomHsh(int size, int order) {
  MaterialMaps m;
  m.width = m.height = size;
  m.model = ShadingModel::kHsh;
  m.basis_terms = order * order;
  m.normal = Image(size, size, 3);
  m.albedo = Image(size, size, 3);
  m.mask = Image(size, size, 1, 1.0f);
  m.height_map = Image(size, size, 1);
  m.coefficients = Image(size, size, 3 * order * order);
  for (int q = 0; q < 3 * order * order; ++q)
    for (int64_t p = 0; p < int64_t(size) * size; ++p)
      m.coefficients.Plane(q)[p] = float(synth::HashUniform(11, q, p) - 0.4);
  return m;
}

TEST(Hsh, ReconstructsDataFromItsOwnBasisExactly) {
  for (int order : {2, 3}) {
    const MaterialMaps truth = RandomHsh(12, order);
    const LightStack s = synth::RenderStack(truth, *synth::MakeLightSet("bonn81", 1), {});
    auto fit = FitHsh(s, {}, order);
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    double worst = 0;
    for (size_t k = 0; k < truth.coefficients.data().size(); ++k)
      worst = std::max(
          worst, double(std::abs(fit->maps.coefficients.data()[k] - truth.coefficients.data()[k])));
    EXPECT_LT(worst, 2e-4) << order;
    EXPECT_LT(Reconstruction(s, fit->maps, fit->status).rmse, 1e-5) << order;
  }
}

TEST(Hsh, TooFewOrDegenerateLightsAreRejected) {
  const MaterialMaps truth = RandomHsh(4, 3);
  const LightStack ring = synth::RenderStack(truth, *synth::MakeLightSet("ring12", 1), {});
  auto r = FitHsh(ring, {}, 3);
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("rank < 9"), std::string::npos);
  const LightStack few = synth::RenderStack(truth, *synth::MakeLightSet("dome:5", 1), {});
  EXPECT_FALSE(FitHsh(few, {}, 3).ok());
  EXPECT_TRUE(FitHsh(few, {}, 2).ok());
}

}  // namespace
}  // namespace matfit::fit
