// Fits on the real psm sets (skipped when ../shared/data is absent).
#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "core/dataset/dataset.h"
#include "fit/methods.h"
#include "fit/metrics.h"

namespace matfit::fit {
namespace {

std::string SharedDir() {
  if (const char* env = std::getenv("MATFIT_SHARED_DATA")) return env;
  return MATFIT_SHARED_DATA;
}

// The grey object is a near-Lambertian blob facing the camera: at the mask centroid the
// normal faces the viewer, at the rightmost masked texel of that row it points right, and at
// the topmost texel of the centroid column it points up (y up: the TGA orientation and the
// lights agree).
TEST(RealDataFit, LambertNormalsOnPsmGrayPointTheRightWay) {
  const std::string dir = SharedDir() + "/psm/gray";
  if (!std::filesystem::exists(dir)) GTEST_SKIP() << "shared data 'psm/gray' not found; skipping";
  auto s = ReadDataset(dir);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  auto fit = FitLambert(*s, {});
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  const int W = s->width(), H = s->height();
  double cx = 0, cy = 0, count = 0;
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x)
      if (s->mask[size_t(y) * W + x]) cx += x, cy += y, count += 1;
  cx /= count, cy /= count;
  const int ix = int(cx), iy = int(cy);
  const auto n = [&](int c, int y, int x) { return fit->maps.normal.At(c, y, x); };
  EXPECT_GT(n(2, iy, ix), 0.8);
  int right = ix, top = iy;
  while (right + 1 < W && s->mask[size_t(iy) * W + right + 1]) ++right;
  while (top > 0 && s->mask[size_t(top - 1) * W + ix]) --top;
  EXPECT_GT(n(0, iy, right - 3), 0.4) << "right edge should face +x";
  EXPECT_GT(n(1, top + 3, ix), 0.4) << "top edge should face +y (up)";
  EXPECT_LT(double(fit->flagged_texels) / s->MaskedTexels(), 0.01);
  const ReconstructionMetrics rec = Reconstruction(*s, fit->maps, fit->status);
  EXPECT_LT(rec.rmse, 0.05);  // near-Lambertian: small residual (measured 0.0163, 35.8 dB)
  std::printf("psm/gray lambert: rmse %.4f, psnr %.1f dB, flagged %lld of %lld\n", rec.rmse,
              rec.psnr_db, (long long)fit->flagged_texels, (long long)s->MaskedTexels());
}

}  // namespace
}  // namespace matfit::fit
