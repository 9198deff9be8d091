// The real measured datasets in ../shared/data (skipped when the folder is absent).
#include <gtest/gtest.h>

#include <filesystem>
#include <utility>

#include "core/dataset/dataset.h"
#include "core/dataset/info.h"
#include "core/text_file.h"
#include "tests/core/test_util.h"

namespace matfit {
namespace {

class PsmSet : public ::testing::TestWithParam<const char*> {};

TEST_P(PsmSet, ReadsTwelveImagesMaskAndLights) {
  MATFIT_REQUIRE_SHARED_DATA("psm");
  const std::string dir = shared_dir + "/psm/" + GetParam();
  std::string reason;
  auto layout = DetectLayout(dir, &reason);
  ASSERT_TRUE(layout.ok()) << layout.status().ToString();
  EXPECT_EQ(*layout, Layout::kLightsTxt) << reason;
  auto s = ReadDataset(dir);
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->num_images(), 12);
  EXPECT_EQ(s->width(), 512);
  EXPECT_EQ(s->height(), 340);
  EXPECT_EQ(s->channels(), 3);
  EXPECT_EQ(s->object_name, GetParam());
  EXPECT_TRUE(s->has_mask());
  EXPECT_GT(s->MaskedTexels(), 10000);
  EXPECT_EQ(s->encodings[0].transfer, TransferFunction::kSrgb);  // 8-bit TGA, no metadata
  // Light 0 is (0.403259, 0.480808, 0.778592) up to normalisation.
  EXPECT_LT(AngleBetweenDeg(s->lights()[0].direction, Vec3(0.403259, 0.480808, 0.778592)), 1e-4);
  EXPECT_NEAR(Length(s->lights()[11].direction), 1.0, 1e-12);
}

INSTANTIATE_TEST_SUITE_P(Objects, PsmSet, ::testing::Values("gray", "cat", "chrome"));

// Orientation: the TGA origin flag must be honoured. With y up, light 0 = (0.40, 0.48, 0.78)
// puts the chrome highlight up and to the right of the sphere's centre.
TEST(RealData, ChromeHighlightAgreesWithLightZeroWhenTgaIsUpright) {
  MATFIT_REQUIRE_SHARED_DATA("psm/chrome");
  auto s = ReadDataset(shared_dir + "/psm/chrome");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  double cx = 0, cy = 0, count = 0;
  for (int y = 0; y < s->height(); ++y)
    for (int x = 0; x < s->width(); ++x)
      if (s->mask[size_t(y) * s->width() + x]) cx += x, cy += y, count += 1;
  ASSERT_GT(count, 0);
  cx /= count, cy /= count;
  int bx = 0, by = 0;
  float best = -1;
  for (int y = 0; y < s->height(); ++y)
    for (int x = 0; x < s->width(); ++x) {
      if (!s->mask[size_t(y) * s->width() + x]) continue;
      const float v = std::as_const(*s).At(0, 0, y, x) + std::as_const(*s).At(0, 1, y, x) +
                      std::as_const(*s).At(0, 2, y, x);
      if (v > best) best = v, bx = x, by = y;
    }
  EXPECT_GT(bx, cx) << "highlight should be right of centre";
  EXPECT_LT(by, cy) << "highlight should be above centre (row index smaller)";
}

TEST(RealData, LeafSheetTopLights) {
  MATFIT_REQUIRE_SHARED_DATA("leaf-sheet/top_lights.lp");
  auto s = ReadDataset(shared_dir + "/leaf-sheet/top_lights.lp");
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  EXPECT_EQ(s->layout, "lp");
  EXPECT_EQ(s->num_images(), 12);
  EXPECT_EQ(s->width(), 500);
  EXPECT_EQ(s->height(), 333);
  for (int n = 1; n <= 12; ++n) {
    const LightSample& l = s->lights()[n - 1];
    EXPECT_NEAR(l.theta_deg, 45.0, 0.01);
    double expected = 225.0 - 30.0 * (n - 1);
    if (expected < 0) expected += 360;
    EXPECT_NEAR(l.phi_deg, expected, 0.01) << "image " << n;
    EXPECT_NE(s->image_files[n - 1].find(std::to_string(n) + "_TL.png"), std::string::npos);
  }
  // The PNGs carry gAMA 1/2.2: decoded with that curve (the file says so).
  EXPECT_EQ(s->encodings[0].transfer, TransferFunction::kGamma);
  EXPECT_NEAR(s->encodings[0].gamma, 2.2f, 1e-3);
  // Folder form detects the same layout.
  std::string reason;
  auto layout = DetectLayout(shared_dir + "/leaf-sheet", &reason);
  ASSERT_TRUE(layout.ok());
  EXPECT_EQ(*layout, Layout::kLp);
}

TEST(RealData, PsmInfoReportsTheLightMatrix) {
  MATFIT_REQUIRE_SHARED_DATA("psm/gray");
  auto s = ReadDataset(shared_dir + "/psm/gray");
  ASSERT_TRUE(s.ok());
  const DatasetInfo info = ComputeDatasetInfo(*s);
  EXPECT_EQ(info.rank, 3);
  // The psm lights lie in a cone of about 40°: well posed but not tiny.
  EXPECT_GT(info.condition_number, 1.5);
  EXPECT_LT(info.condition_number, 30);
  EXPECT_LT(info.theta_max, 45);
}

}  // namespace
}  // namespace matfit
