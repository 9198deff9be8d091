// Relighting check: the plane scene of a fitted pack, rendered at a dataset's own light
// directions and intensities (linear output, one pixel per texel), reproduces the measured
// images with the RMSE that the fit reports. Ties the renderers to the fit metrics.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <memory>
#include <vector>

#include "core/dataset/dataset.h"
#include "fit/method.h"
#include "fit/metrics.h"
#include "render/cpu_renderer.h"
#include "render/egl_renderer.h"

namespace matfit::render {
namespace {

double RelitRmse(const LightStack& s, const fit::FitResult& fit, EglRenderer* egl) {
  double sum = 0;
  int64_t n = 0;
  for (int i = 0; i < s.num_images(); ++i) {
    RenderOptions o;
    o.size = s.width();
    o.display = false;
    const Vec3& d = s.lights()[i].direction;
    o.theta_deg = std::acos(std::clamp(d.z, -1.0, 1.0)) * 180 / M_PI;
    o.phi_deg = std::atan2(d.y, d.x) * 180 / M_PI;
    o.light_color = s.lights()[i].intensity;
    auto img = egl ? egl->Render(fit.maps, o) : RenderCpu(fit.maps, o);
    EXPECT_TRUE(img.ok()) << img.status().ToString();
    if (!img.ok()) return -1;
    for (int64_t p = 0; p < s.plane_size(); ++p) {
      if (fit.status[p] != 0) continue;
      for (int c = 0; c < s.channels(); ++c) {
        const double e = s.Sample(i, c, p) - img->Plane(c)[p];
        sum += e * e, ++n;
      }
    }
  }
  return std::sqrt(sum / double(n));
}

TEST(Relight, RenderedPlaneAtTheDatasetLightsReproducesTheReportedError) {
  auto egl = EglRenderer::Create();
  if (!egl.ok()) std::printf("EGL unavailable (%s): CPU only\n", egl.status().message().c_str());
  const std::string root = MATFIT_SOURCE_DIR "/fixtures/";
  for (const auto& [dataset, model] :
       std::vector<std::pair<std::string, std::string>>{{"plaster-bonn81", "lambert"},
                                                        {"plastic-ring12", "blinn-phong"},
                                                        {"plaster-bonn81", "ptm"},
                                                        {"wool-bonn81-8bit", "ptm-srgb"},
                                                        {"wool-bonn81-8bit", "heinrich"}}) {
    auto s = ReadDataset(root + dataset);
    ASSERT_TRUE(s.ok()) << s.status().ToString();
    ASSERT_EQ(s->width(), s->height()) << dataset;
    auto fit = fit::MakeMethod(model)->Fit(*s, {});
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    const double reported = fit::Reconstruction(*s, fit->maps, fit->status).rmse;
    ASSERT_GT(reported, 0) << dataset << " " << model;
    std::vector<EglRenderer*> backends = {nullptr};  // nullptr: the CPU renderer
    if (egl.ok()) backends.push_back(egl->get());
    for (EglRenderer* r : backends) {
      const double relit = RelitRmse(*s, *fit, r);
      EXPECT_NEAR(relit, reported, 1e-3 * reported + 1e-6)
          << dataset << " " << model << (r ? " (EGL)" : " (CPU)");
    }
  }
}

}  // namespace
}  // namespace matfit::render
