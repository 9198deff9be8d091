#include <gtest/gtest.h>

#include <map>

#include "core/synth/light_sets.h"

namespace matfit::synth {
namespace {

TEST(LightSets, Bonn81MatchesMethodsSection1) {
  auto l = MakeLightSet("bonn81", 1);
  ASSERT_TRUE(l.ok());
  ASSERT_EQ(l->size(), 81u);
  std::map<int, int> per_theta;
  Vec3 mean;
  for (const auto& s : *l) {
    per_theta[int(s.theta_deg)]++;
    mean += s.direction / 81.0;
    EXPECT_NEAR(Length(s.direction), 1.0, 1e-12);
  }
  EXPECT_EQ(per_theta,
            (std::map<int, int>{{0, 1}, {15, 6}, {30, 12}, {45, 18}, {60, 20}, {75, 24}}));
  // METHODS.md §2: the mean light direction is (0, 0, 0.5695).
  EXPECT_NEAR(mean.x, 0.0, 1e-12);
  EXPECT_NEAR(mean.y, 0.0, 1e-12);
  EXPECT_NEAR(mean.z, 0.5695, 5e-5);
  // φ spacing: every 20° at θ = 45°.
  EXPECT_DOUBLE_EQ((*l)[1 + 6 + 12 + 1].phi_deg, 20.0);
}

TEST(LightSets, RingDomeRandom) {
  auto ring = MakeLightSet("ring12", 1);
  ASSERT_TRUE(ring.ok());
  ASSERT_EQ(ring->size(), 12u);
  for (int k = 0; k < 12; ++k) {
    EXPECT_NEAR((*ring)[k].theta_deg, 45.0, 1e-9);
    EXPECT_NEAR((*ring)[k].phi_deg, 30.0 * k, 1e-9);
  }
  auto ring30 = MakeLightSet("ring:5:30", 1);
  ASSERT_TRUE(ring30.ok());
  EXPECT_NEAR((*ring30)[3].theta_deg, 30.0, 1e-9);
  auto dome = MakeLightSet("dome:50", 1);
  ASSERT_TRUE(dome.ok());
  ASSERT_EQ(dome->size(), 50u);
  for (const auto& s : *dome) EXPECT_LE(s.theta_deg, 75.0 + 1e-9);
  auto a = MakeLightSet("random:20", 7), b = MakeLightSet("random:20", 7),
       c = MakeLightSet("random:20", 8);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  for (int k = 0; k < 20; ++k) {
    EXPECT_EQ((*a)[k].direction, (*b)[k].direction);
    EXPECT_LE((*a)[k].theta_deg, 80.0 + 1e-9);
  }
  EXPECT_NE((*a)[0].direction, (*c)[0].direction);
}

TEST(LightSets, BadSpecsAreRejected) {
  for (const char* bad : {"bonn80", "ring:0", "ring:4:95", "dome:", "random:x", "dome:4:3", ""}) {
    auto l = MakeLightSet(bad, 1);
    EXPECT_FALSE(l.ok()) << bad;
    if (!l.ok()) {
      EXPECT_NE(l.status().message().find("--lights"), std::string::npos);
    }
  }
}

TEST(LightSets, QuantizeToIntegerDegrees) {
  auto l = MakeLightSet("random:10", 3);
  ASSERT_TRUE(l.ok());
  QuantizeToIntegerDegrees(&*l);
  for (const auto& s : *l) {
    EXPECT_EQ(s.theta_deg, std::round(s.theta_deg));
    EXPECT_EQ(s.phi_deg, std::round(s.phi_deg));
    EXPECT_LT(AngleBetweenDeg(s.direction, DirectionFromAnglesDeg(s.theta_deg, s.phi_deg)), 1e-9);
  }
}

}  // namespace
}  // namespace matfit::synth
