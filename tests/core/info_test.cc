#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/dataset/info.h"
#include "core/synth/light_sets.h"

namespace matfit {
namespace {

LightStack StackWith(const std::vector<Vec3>& dirs) {
  LightStack s(4, 4, 3, int(dirs.size()));
  for (size_t i = 0; i < dirs.size(); ++i) {
    s.lights()[i].direction = Normalize(dirs[i]);
    AnglesDegFromDirection(s.lights()[i].direction, &s.lights()[i].theta_deg,
                           &s.lights()[i].phi_deg);
    for (int c = 0; c < 3; ++c)
      for (float& v : s.Plane(int(i), c)) v = 0.5f;
  }
  return s;
}

bool HasWarning(const DatasetInfo& d, const std::string& text) {
  for (const auto& w : d.warnings)
    if (w.find(text) != std::string::npos) return true;
  return false;
}

TEST(Info, Bonn81GroupsAndConditionNumber) {
  LightStack s(4, 4, 3, 81);
  s.lights() = *synth::MakeLightSet("bonn81", 1);
  for (int i = 0; i < 81; ++i)
    for (int c = 0; c < 3; ++c)
      for (float& v : s.Plane(i, c)) v = 0.4f;
  const DatasetInfo d = ComputeDatasetInfo(s);
  ASSERT_EQ(d.theta_groups.size(), 6u);
  EXPECT_EQ(d.theta_groups[5].theta_deg, 75);
  EXPECT_EQ(d.theta_groups[5].count, 24);
  // LᵀL is diagonal: Σx² = Σy² = ½ Σ sin²θ, Σz² = Σ cos²θ; cond = sqrt(λmax/λmin).
  const int th[] = {0, 15, 30, 45, 60, 75}, cnt[] = {1, 6, 12, 18, 20, 24};
  double sx = 0, sz = 0;
  for (int k = 0; k < 6; ++k) {
    const double t = th[k] * M_PI / 180;
    sx += 0.5 * cnt[k] * std::sin(t) * std::sin(t);
    sz += cnt[k] * std::cos(t) * std::cos(t);
  }
  EXPECT_NEAR(d.condition_number, std::sqrt(std::max(sx, sz) / std::min(sx, sz)), 1e-9);
  EXPECT_NEAR(d.mean_light.z, 0.5695, 5e-5);
  EXPECT_TRUE(d.warnings.empty()) << d.warnings.front();
}

TEST(Info, WarnsAboutTooFewAndCoplanarLights) {
  const DatasetInfo two = ComputeDatasetInfo(StackWith({{0, 0, 1}, {1, 0, 1}}));
  EXPECT_TRUE(HasWarning(two, "only 2 light(s)"));
  // All in the x–z plane: rank 2.
  const DatasetInfo coplanar =
      ComputeDatasetInfo(StackWith({{0, 0, 1}, {1, 0, 1}, {-1, 0, 1}, {1, 0, 3}}));
  EXPECT_EQ(coplanar.rank, 2);
  EXPECT_FALSE(std::isfinite(coplanar.condition_number));
  EXPECT_TRUE(HasWarning(coplanar, "coplanar"));
  // Nearly coplanar: a tiny y component.
  const DatasetInfo nearly =
      ComputeDatasetInfo(StackWith({{0, 0, 1}, {1, 0.001, 1}, {-1, 0, 1}, {1, -0.001, 3}}));
  EXPECT_EQ(nearly.rank, 3);
  EXPECT_TRUE(HasWarning(nearly, "ill-conditioned"));
  const DatasetInfo below =
      ComputeDatasetInfo(StackWith({{0, 0, 1}, {1, 0, 1}, {0, 1, 1}, {0, 1, -1}}));
  EXPECT_TRUE(HasWarning(below, "below the surface"));
}

TEST(Info, WarnsAboutClippedBlackAndNonFinite) {
  LightStack s = StackWith({{0, 0, 1}, {1, 0, 1}, {0, 1, 1}});
  s.image_files = {"a.png", "b.png", "c.png"};
  s.saturated_pixels = {0, 8, 0};
  s.nonfinite_samples = {0, 0, 3};
  for (int c = 0; c < 3; ++c)
    for (float& v : s.Plane(2, c)) v = 0.0f;
  const DatasetInfo d = ComputeDatasetInfo(s);
  EXPECT_NEAR(d.saturated_fraction, 8.0 / 48, 1e-12);
  EXPECT_EQ(d.worst_saturated_file, "b.png");
  EXPECT_TRUE(HasWarning(d, "clipped"));
  EXPECT_TRUE(HasWarning(d, "3 NaN/Inf"));
  EXPECT_TRUE(HasWarning(d, "black"));
  const auto j = nlohmann::json::parse(DatasetInfoJson(d));
  EXPECT_EQ(j["images"], 3);
  EXPECT_EQ(j["warnings"].size(), d.warnings.size());
  EXPECT_NE(FormatDatasetInfo(d).find("condition number"), std::string::npos);
}

}  // namespace
}  // namespace matfit
