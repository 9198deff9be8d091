// The micro-geometry material (issue 19): each part of its light transport does what it says.
#include <gtest/gtest.h>
#include <cmath>
#include <vector>

#include "core/parallel.h"
#include "core/synth/micro_geometry.h"
#include "core/synth/synth.h"

namespace matfit::synth {
namespace {

double Mean(const std::vector<float>& v) {
  double s = 0;
  for (float x : v) s += x;
  return s / double(v.size());
}

std::vector<float> Render(const MicroSurface& s, const Vec3& l, const Vec3& v = {0, 0, 1}) {
  std::vector<float> out(size_t(3) * s.width * s.height);
  RenderMicroLight(s, Normalize(l), Normalize(v), out.data());
  return out;
}

MicroSurface Surface(const MicroGeometryOptions& o, int size = 16) {
  auto s = MakeMicroSurface(size, size, 7, o);
  EXPECT_TRUE(s.ok()) << s.status().ToString();
  return std::move(*s);
}

TEST(MicroGeometry, AFlatMatteSurfaceReadsAlbedoTimesCosine) {
  MicroGeometryOptions o;
  o.bump_height = 0, o.relief = 0, o.specular = false;  // shadows, masking and bounce stay on
  const MicroSurface s = Surface(o);
  const int64_t T = int64_t(s.width) * s.height;
  for (const Vec3& l : {Vec3(0, 0, 1), Vec3(0.5, 0.2, 0.8), Vec3(-0.9, 0.1, 0.3)}) {
    const std::vector<float> r = Render(s, l);
    const double cos_l = Normalize(l).z;
    for (int c = 0; c < 3; ++c)
      for (int64_t p = 0; p < T; ++p)
        ASSERT_NEAR(r[size_t(c * T + p)], s.albedo[size_t(c * T + p)] * cos_l, 1e-6);
  }
  const MaterialMaps truth = MicroTruthMaps(s);
  for (int64_t p = 0; p < T; ++p) EXPECT_NEAR(truth.normal.data()[size_t(2 * T + p)], 1.0, 1e-9);
}

TEST(MicroGeometry, EachPartOfTheTransportActsWhereItShould) {
  MicroGeometryOptions all;
  const MicroSurface s = Surface(all);
  MicroGeometryOptions no_shadow = all, no_bounce = all, no_mask = all;
  no_shadow.shadows = false, no_bounce.bounce = false, no_mask.masking = false;
  const MicroSurface s_ns = Surface(no_shadow), s_nb = Surface(no_bounce), s_nm = Surface(no_mask);
  const Vec3 grazing = DirectionFromAnglesDeg(75, 30), frontal(0, 0, 1);
  // Self-shadowing darkens grazing light, and a frontal light casts no shadow.
  EXPECT_LT(Mean(Render(s, grazing)), 0.9 * Mean(Render(s_ns, grazing)));
  EXPECT_EQ(Render(s, frontal), Render(s_ns, frontal));
  // One bounce adds light, less than the direct light itself.
  const double with = Mean(Render(s, frontal)), without = Mean(Render(s_nb, frontal));
  EXPECT_GT(with, 1.01 * without);
  EXPECT_LT(with, 1.5 * without);
  // Masking acts only away from the frontal view.
  EXPECT_EQ(Render(s, grazing, frontal), Render(s_nm, grazing, frontal));
  const Vec3 oblique = DirectionFromAnglesDeg(70, 200);
  EXPECT_NE(Render(s, frontal, oblique), Render(s_nm, frontal, oblique));
  // Facets face many ways: a micro-facet highlight appears near the mirror configuration and
  // its absence leaves only the diffuse readings.
  MicroGeometryOptions matte = all;
  matte.specular = false;
  const MicroSurface s_matte = Surface(matte);
  EXPECT_GT(Mean(Render(s, frontal)), Mean(Render(s_matte, frontal)));
}

TEST(MicroGeometry, RenderingIsDeterministicAndIndependentOfThreads) {
  const MicroSurface s = Surface({}, 12);
  const Vec3 l = DirectionFromAnglesDeg(50, 120);
  const std::vector<float> a = Render(s, l);
  const int before = NumThreads();
  SetNumThreads(1);
  const MicroSurface s1 = Surface({}, 12);
  const std::vector<float> b = Render(s1, l);
  SetNumThreads(before);
  EXPECT_EQ(a, b);
}

TEST(MicroGeometry, SynthWritesItsTruthAsMacroNormalAndAlbedoAndKeepsTheSurface) {
  SynthOptions o;
  o.material = "micro-stone";
  o.lights = "dome:12";
  o.size = 16;
  auto r = Synthesize(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_TRUE(r->micro_surface);
  EXPECT_EQ(r->stack.num_images(), 12);
  EXPECT_NE(r->params_json.find("\"appearance\": \"micro-geometry\""), std::string::npos);
  // The stack is the surface's render (no perturbation asked for).
  const std::vector<float> first = Render(*r->micro_surface, r->stack.lights()[0].direction);
  const int64_t T = r->stack.plane_size();
  for (int64_t p = 0; p < T; ++p) ASSERT_EQ(r->stack.Plane(0, 1)[p], first[size_t(T + p)]);
  EXPECT_FALSE(MakeMicroSurface(600, 600, 1).ok());  // the tables' size is capped
}

}  // namespace
}  // namespace matfit::synth
