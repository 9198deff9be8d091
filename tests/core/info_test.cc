#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/color.h"
#include "core/dataset/info.h"
#include "core/sample_type.h"
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

// Native-depth stacks decide "black" from their codes (issue 16): an image is black exactly when
// no sample decodes to ≥ 1e-4, the same answer as decoding every sample.
TEST(Info, BlackImagesOfNativeDepthStacksMatchTheDecodedValues) {
  for (const SampleType type : {SampleType::kUint8, SampleType::kUint16}) {
    const int codes = SampleCodes(type);
    std::vector<float> lut(static_cast<size_t>(codes));
    for (int k = 0; k < codes; ++k) lut[size_t(k)] = SrgbToLinear(float(k) / float(codes - 1));
    // The first code that decodes to ≥ 1e-4, and the one below it.
    int bright = 0;
    while (lut[size_t(bright)] < 1e-4f) ++bright;
    ASSERT_GT(bright, 0);
    LightStack s(4, 4, 3, 3, type, lut);
    s.lights()[1].direction = Normalize(Vec3(1, 0, 1));
    s.lights()[2].direction = Normalize(Vec3(0, 1, 1));
    auto set = [&](int i, int c, int p, int code) {
      if (type == SampleType::kUint8)
        s.Codes<uint8_t>(i, c)[size_t(p)] = uint8_t(code);
      else
        s.Codes<uint16_t>(i, c)[size_t(p)] = uint16_t(code);
    };
    for (int c = 0; c < 3; ++c) set(0, c, 5, bright - 1);  // every sample below 1e-4: black
    set(1, 2, 15, bright);                                 // one blue sample at 1e-4: not black
    set(2, 0, 0, codes - 1);                               // white corner: not black
    const DatasetInfo d = ComputeDatasetInfo(s);
    EXPECT_TRUE(HasWarning(d, "1 image(s) are black")) << SampleTypeName(type);
    EXPECT_TRUE(HasWarning(d, "first: '0'")) << SampleTypeName(type);
    // The float copy (every sample decoded) says the same.
    const DatasetInfo f = ComputeDatasetInfo(s.ToFloat());
    EXPECT_TRUE(HasWarning(f, "1 image(s) are black")) << SampleTypeName(type);
  }
}

}  // namespace
}  // namespace matfit
