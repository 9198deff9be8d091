// Preview renderers: the CPU reference against the shared shading code, and the EGL renderer
// (the GLSL port of that code) against the CPU reference for every model of the ladder.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <memory>

#include "core/color.h"
#include "core/pack/pack.h"
#include "core/pack/pack_reader.h"
#include "core/synth/materials.h"
#include "core/synth/synth.h"
#include "fit/method.h"
#include "render/cpu_renderer.h"
#include "render/egl_renderer.h"

namespace matfit::render {
namespace {

// Every model of the ladder on one small material: fitted from a synthetic wool stack (the fit's
// own output format), plus the synthetic generator's Blinn–Phong / Cook–Torrance truth.
const std::map<std::string, MaterialMaps>& Materials() {
  static const auto* all = [] {
    auto* m = new std::map<std::string, MaterialMaps>;
    synth::SynthOptions o;
    o.material = "wool";
    o.lights = "bonn81";
    o.size = 32;
    o.layout = Layout::kLp;
    const LightStack s = synth::Synthesize(o)->stack;
    for (const char* name : {"mean", "lambert", "heinrich", "ptm", "ptm-srgb", "hsh2", "hsh3",
                             "hsh3-srgb", "lafortune1", "lafortune2", "rbf", "rbf-srgb"}) {
      auto method = fit::MakeMethod(name);
      auto r = method->Fit(s, {});
      if (r.ok()) (*m)[name] = std::move(r->maps);
    }
    (*m)["blinn-phong"] = *synth::MakeMaterial("plastic", 32, 1);
    (*m)["cook-torrance"] = *synth::MakeMaterial("plastic-ct", 32, 1);
    // Two-sided leaves: the diffuse-BTDF fallback, and HL2 coefficients with texel variation.
    MaterialMaps leaf = *synth::MakeMaterial("leaf", 32, 1);
    (*m)["leaf"] = leaf;
    leaf.hl2 = Image(32, 32, 3);
    for (int i = 0; i < 3; ++i)
      for (int64_t p = 0; p < 32 * 32; ++p)
        leaf.hl2.Plane(i)[p] = float(0.835543 * (0.7 + 0.6 * ((p * (i + 3)) % 17) / 17.0));
    (*m)["leaf-hl2"] = leaf;
    return m;
  }();
  return *all;
}

EglRenderer* Egl() {
  static auto r = EglRenderer::Create();
  return r.ok() ? r->get() : nullptr;
}

TEST(CpuRenderer, HeadOnLambertPlaneShowsTheAlbedo) {
  MaterialMaps m = *synth::MakeMaterial("plaster", 16, 1);
  for (float& v : m.normal.Plane(0)) v = 0;
  for (float& v : m.normal.Plane(1)) v = 0;
  for (float& v : m.normal.Plane(2)) v = 1;
  RenderOptions o;
  o.size = 16;
  o.theta_deg = 0;
  auto img = RenderCpu(m, o);
  ASSERT_TRUE(img.ok()) << img.status().ToString();
  for (int c = 0; c < 3; ++c)
    for (int64_t p = 0; p < 256; ++p)
      EXPECT_NEAR(img->Plane(c)[p], LinearToSrgb(m.albedo.Plane(c)[p]), 1e-6);
  o.display = false;
  o.theta_deg = 60;  // linear output: ρ cos 60°
  img = RenderCpu(m, o);
  ASSERT_TRUE(img.ok());
  EXPECT_NEAR(img->Plane(1)[37], 0.5 * m.albedo.Plane(1)[37], 1e-6);
}

TEST(CpuRenderer, SphereHasBackgroundOutsideAndIsDarkOppositeTheLight) {
  RenderOptions o;
  o.scene = Scene::kSphere;
  o.size = 64;
  o.theta_deg = 60, o.phi_deg = 0;  // light from the right
  auto img = RenderCpu(Materials().at("lambert"), o);
  ASSERT_TRUE(img.ok());
  EXPECT_EQ(img->Plane(3)[0], 0.0f);              // corner: background
  EXPECT_EQ(img->Plane(3)[32 * 64 + 32], 1.0f);   // centre: sphere
  EXPECT_GT(img->Plane(1)[32 * 64 + 56], 0.05f);  // lit right limb
  EXPECT_EQ(img->Plane(1)[32 * 64 + 4], 0.0f);    // left limb faces away from the light
}

TEST(CpuRenderer, BackLitLeafShowsItsTranslucency) {
  MaterialMaps leaf = Materials().at("leaf");
  RenderOptions o;
  o.size = 32;
  o.display = false;
  o.theta_deg = 180;  // straight from behind: diffuse BTDF ρ_t · 1
  auto img = RenderCpu(leaf, o);
  ASSERT_TRUE(img.ok());
  int64_t checked = 0;
  for (int64_t p = 0; p < 32 * 32; ++p)
    if (leaf.mask.Plane(0)[p] > 0.5f) {
      EXPECT_NEAR(img->Plane(1)[p], leaf.translucency.Plane(1)[p], 1e-6);
      ++checked;
    }
  EXPECT_GT(checked, 100);
  // HL2 coefficients of pure diffuse translucency, √(2π)/3 each, reproduce the same image.
  leaf.hl2 = Image(32, 32, 3, 0.83554350f);
  o.theta_deg = 150, o.phi_deg = 30;
  auto a = RenderCpu(Materials().at("leaf"), o), b = RenderCpu(leaf, o);
  ASSERT_TRUE(a.ok() && b.ok());
  for (int64_t p = 0; p < 32 * 32; ++p) EXPECT_NEAR(a->Plane(0)[p], b->Plane(0)[p], 1e-6);
}

TEST(CpuRenderer, LeafPackRoundTripRendersTheSame) {
  const MaterialMaps& leaf = Materials().at("leaf-hl2");
  const std::string dir = ::testing::TempDir() + "/matfit-leaf-pack";
  PackWriteOptions w;
  w.overwrite = true;
  ASSERT_TRUE(WritePack(leaf, std::vector<uint8_t>(32 * 32, 0), {}, w, dir).ok());
  auto back = ReadPack(dir);
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  ASSERT_FALSE(back->maps.hl2.empty());
  ASSERT_FALSE(back->maps.translucency.empty());
  for (double theta : {30.0, 150.0}) {
    RenderOptions o;
    o.size = 32, o.theta_deg = theta, o.display = false;
    auto a = RenderCpu(leaf, o), b = RenderCpu(back->maps, o);
    ASSERT_TRUE(a.ok() && b.ok());
    for (size_t k = 0; k < a->data().size(); ++k) ASSERT_NEAR(a->data()[k], b->data()[k], 1e-6);
  }
}

TEST(CpuRenderer, RejectsBadOptionsAndIncompleteMaterials) {
  RenderOptions o;
  o.size = 2;
  EXPECT_FALSE(RenderCpu(Materials().at("lambert"), o).ok());
  MaterialMaps m = Materials().at("blinn-phong");
  m.exponent = Image();
  auto r = RenderCpu(m, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("exponent"), std::string::npos) << r.status().message();
}

// The agreement contract (docs/render.md): display-encoded 8-bit values of the EGL and CPU
// renders differ by at most 2/255 per channel on at least 99.5 % of pixels.
TEST(EglRenderer, MatchesTheCpuReferenceForEveryModel) {
  if (!Egl()) GTEST_SKIP() << EglRenderer::Create().status().ToString();
  ASSERT_EQ(Materials().size(), 16u);
  int64_t all_off = 0, all_total = 0, exact = 0;
  double all_worst = 0;
  for (Scene scene : {Scene::kPlane, Scene::kSphere, Scene::kCloth})
    for (const auto& [name, maps] : Materials())
      for (double theta : {0.0, 35.0, 70.0, 140.0}) {  // 140°: from behind (leaves transmit)
        RenderOptions o;
        // The camera looks straight down, except for the 35° light: tilted by 40° toward φ 200°.
        if (theta == 35.0) o.camera_theta_deg = 40, o.camera_phi_deg = 200;
        o.scene = scene;
        o.size = 96;
        o.theta_deg = theta, o.phi_deg = 120;
        o.ambient = 0.05;
        auto cpu = RenderCpu(maps, o);
        auto gpu = Egl()->Render(maps, o);
        ASSERT_TRUE(cpu.ok() && gpu.ok()) << name << ": " << gpu.status().ToString();
        int64_t off = 0, total = 0;
        double worst = 0;
        for (int c = 0; c < 4; ++c)
          for (int64_t p = 0; p < int64_t(o.size) * o.size; ++p) {
            const double d =
                std::abs(std::round(255 * cpu->Plane(c)[p]) - std::round(255 * gpu->Plane(c)[p]));
            worst = std::max(worst, d);
            off += d > 2;
            exact += d == 0;
            ++total;
          }
        all_off += off, all_total += total, all_worst = std::max(all_worst, worst);
        double lit = 0;  // the render must show the material, not a blank frame
        for (int64_t p = 0; p < int64_t(o.size) * o.size; ++p) lit += gpu->Plane(1)[p] > 0.02f;
        if (theta < 90 || name.rfind("leaf", 0) == 0) {
          EXPECT_GT(lit, 0.05 * o.size * o.size) << name << " " << SceneName(scene) << " " << theta;
        }
        EXPECT_LE(double(off), 0.005 * double(total))
            << name << " " << SceneName(scene) << " θ=" << theta << ": " << off << " of " << total
            << " values off by > 2/255 (worst " << worst << ")";
      }
  std::printf(
      "EGL vs CPU, 16 materials × 3 scenes × 4 lights: %.4f %% of values off by > 2/255, "
      "%.2f %% identical, worst %.0f/255\n",
      100.0 * double(all_off) / double(all_total), 100.0 * double(exact) / double(all_total),
      all_worst);
}

// A non-square material (a leaf crop): 40 × 20 texels keep their 2:1 aspect on the plane, with
// background above and below, identically on both backends.
MaterialMaps Crop(const MaterialMaps& m, int w, int h) {
  MaterialMaps c = m;
  c.width = w, c.height = h;
  for (Image* img : {&c.normal, &c.albedo, &c.height_map, &c.specular, &c.exponent, &c.roughness,
                     &c.thickness, &c.translucency, &c.albedo_back, &c.hl2, &c.mask})
    if (!img->empty()) {
      Image out(w, h, img->channels());
      for (int ch = 0; ch < img->channels(); ++ch)
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) out.At(ch, y, x) = img->At(ch, y, x);
      *img = std::move(out);
    }
  return c;
}

TEST(CpuRenderer, NonSquareMaterialKeepsItsAspectRatio) {
  const MaterialMaps m = Crop(*synth::MakeMaterial("plaster", 40, 1), 40, 20);
  RenderOptions o;
  o.size = 80, o.theta_deg = 0, o.ambient = 0;
  auto img = RenderCpu(m, o);
  ASSERT_TRUE(img.ok()) << img.status().ToString();
  int rows = 0, cols = 0;
  for (int y = 0; y < 80; ++y) rows += img->At(3, y, 40) > 0.5f;  // alpha down the middle
  for (int x = 0; x < 80; ++x) cols += img->At(3, 40, x) > 0.5f;
  EXPECT_EQ(cols, 80);
  EXPECT_EQ(rows, 40);
  EXPECT_EQ(img->At(3, 5, 40), 0.0f);  // above the material: background
}

TEST(EglRenderer, NonSquareMaterialMatchesTheCpu) {
  if (!Egl()) GTEST_SKIP() << EglRenderer::Create().status().ToString();
  for (const char* name : {"leaf-hl2", "cook-torrance"}) {
    const MaterialMaps m = Crop(Materials().at(name), 32, 19);
    for (Scene scene : {Scene::kPlane, Scene::kCloth}) {
      RenderOptions o;
      o.size = 64, o.scene = scene, o.theta_deg = 140, o.phi_deg = 30;
      auto cpu = RenderCpu(m, o);
      auto gpu = Egl()->Render(m, o);
      ASSERT_TRUE(cpu.ok() && gpu.ok());
      int64_t off = 0;
      for (int c = 0; c < 4; ++c)
        for (int64_t p = 0; p < 64 * 64; ++p)
          off +=
              std::abs(std::round(255 * cpu->Plane(c)[p]) - std::round(255 * gpu->Plane(c)[p])) > 2;
      EXPECT_LE(off, 0.005 * 4 * 64 * 64) << name << " " << SceneName(scene);
    }
  }
}

TEST(EglRenderer, LinearOutputMatchesTheCpuRadiance) {
  if (!Egl()) GTEST_SKIP() << EglRenderer::Create().status().ToString();
  RenderOptions o;
  o.display = false;
  o.size = 64;
  o.theta_deg = 40;
  const MaterialMaps& m = Materials().at("cook-torrance");
  auto cpu = RenderCpu(m, o);
  auto gpu = Egl()->Render(m, o);
  ASSERT_TRUE(cpu.ok() && gpu.ok());
  double worst = 0;
  for (int64_t p = 0; p < 64 * 64; ++p)
    worst = std::max(worst, double(std::abs(cpu->Plane(0)[p] - gpu->Plane(0)[p])));
  EXPECT_LT(worst, 1e-3);
}

}  // namespace
}  // namespace matfit::render
