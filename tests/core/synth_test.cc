#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "core/dataset/dataset.h"
#include "core/image_io.h"
#include "core/parallel.h"
#include "core/shading/shading.h"
#include "core/synth/materials.h"
#include "core/synth/render_stack.h"
#include "core/synth/synth.h"
#include "tests/core/test_util.h"

namespace matfit::synth {
namespace {

namespace fs = std::filesystem;
using matfit::testing::TempDir;

SynthOptions Opts(const std::string& material, const std::string& lights, int size, Layout layout,
                  int bits) {
  SynthOptions o;
  o.material = material;
  o.lights = lights;
  o.size = size;
  o.layout = layout;
  o.bits = bits;
  return o;
}

Image Truth(const std::string& dir, const char* name) {
  auto img = ReadImage(dir + "/truth/" + name);
  EXPECT_TRUE(img.ok()) << img.status().ToString();
  return img.ok() ? std::move(*img) : Image();
}

// Written dataset (float EXR) read back == shading functions evaluated on the written truth maps.
class RenderMatchesShading : public ::testing::TestWithParam<const char*> {};

TEST_P(RenderMatchesShading, Exactly) {
  TempDir tmp;
  const std::string dir = tmp / "d";
  const SynthOptions o = Opts(GetParam(), "dome:16", 24, Layout::kLp, 32);
  auto r = Synthesize(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_TRUE(WriteSynthDataset(*r, o, dir, false).ok());
  auto stack = ReadDataset(dir);
  ASSERT_TRUE(stack.ok()) << stack.status().ToString();
  const Image n = Truth(dir, "normal.exr"), albedo = Truth(dir, "albedo.exr");
  const bool bp = r->truth.model == ShadingModel::kBlinnPhong,
             ct = r->truth.model == ShadingModel::kCookTorrance;
  Image spec, expo, rough;
  if (bp || ct) spec = Truth(dir, "specular.exr");
  if (bp) expo = Truth(dir, "exponent.exr");
  if (ct) rough = Truth(dir, "roughness.exr");
  const bool shadows = FindMaterial(GetParam())->self_shadowing;
  const Vec3f v(0, 0, 1);
  double worst = 0;
  int64_t compared = 0;
  for (int i = 0; i < stack->num_images(); ++i) {
    const Vec3f l(r->stack.lights()[i].direction);  // the exact light used to render
    for (int y = 0; y < 24; ++y)
      for (int x = 0; x < 24; ++x) {
        const Vec3f nn(n.At(0, y, x), n.At(1, y, x), n.At(2, y, x));
        for (int c = 0; c < 3; ++c) {
          float expected = shading::Lambert(albedo.At(c, y, x), nn, l);
          if (bp)
            expected += shading::BlinnPhongSpecular(spec.At(0, y, x), expo.At(0, y, x), nn, l, v);
          if (ct)
            expected +=
                shading::CookTorranceSpecular(spec.At(0, y, x), rough.At(0, y, x), nn, l, v);
          const float got = stack->At(i, c, y, x);
          if (shadows && got == 0.0f) continue;  // cast shadow: checked separately
          worst = std::max(worst, double(std::abs(got - expected)));
          ++compared;
        }
      }
  }
  EXPECT_GT(compared, 24 * 24 * 3 * 16 / 2);
  EXPECT_EQ(worst, 0.0);
}

INSTANTIATE_TEST_SUITE_P(Materials, RenderMatchesShading,
                         ::testing::Values("plaster", "plastic", "plastic-ct", "wool", "corduroy",
                                           "granite", "leaf"),
                         [](const auto& param_info) {
                           std::string s = param_info.param;
                           for (char& ch : s)
                             if (ch == '-') ch = '_';
                           return s;
                         });

TEST(Synth, DeterministicForASeedAndThreadCount) {
  SynthOptions o = Opts("wool", "ring12", 32, Layout::kLp, 16);
  o.perturb.gaussian_sigma = 0.01;
  o.perturb.misregister_px = 0.5;
  o.seed = 42;
  SetNumThreads(1);
  auto a = Synthesize(o);
  SetNumThreads(2);
  auto b = Synthesize(o);
  SetNumThreads(0);
  o.seed = 43;
  auto c = Synthesize(o);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(matfit::testing::MaxAbsDiff(a->stack, b->stack), 0.0);
  EXPECT_EQ(a->params_json, b->params_json);
  EXPECT_GT(matfit::testing::MaxAbsDiff(a->stack, c->stack), 0.0);
}

TEST(Synth, GaussianNoiseHasTheRequestedSigma) {
  SynthOptions o = Opts("plaster", "ring12", 64, Layout::kLp, 32);
  auto clean = Synthesize(o);
  o.perturb.gaussian_sigma = 0.02;
  auto noisy = Synthesize(o);
  ASSERT_TRUE(clean.ok() && noisy.ok());
  double sum = 0, sum2 = 0;
  const int64_t n = clean->stack.plane_size() * 3 * 12;
  for (int64_t i = 0; i < n; ++i) {
    const double d = noisy->stack.data()[i] - clean->stack.data()[i];
    sum += d, sum2 += d * d;
  }
  const double mean = sum / n, sigma = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(sigma, 0.02, 0.02 * 0.03);  // 147k samples: ±3 %
  EXPECT_NEAR(mean, 0.0, 0.001);
}

TEST(Synth, ShotNoiseVarianceGrowsWithSignal) {
  SynthOptions o = Opts("plaster", "ring12", 64, Layout::kLp, 32);
  auto clean = Synthesize(o);
  o.perturb.shot_photons = 1000;
  auto noisy = Synthesize(o);
  ASSERT_TRUE(clean.ok() && noisy.ok());
  double num = 0, den = 0;  // E[d²] / E[p] should be 1/K
  const int64_t n = clean->stack.plane_size() * 3 * 12;
  for (int64_t i = 0; i < n; ++i) {
    const double d = noisy->stack.data()[i] - clean->stack.data()[i];
    num += d * d, den += clean->stack.data()[i];
  }
  EXPECT_NEAR(num / den, 1.0 / 1000, 0.05 / 1000);
}

TEST(Synth, ClippingSaturatesAndIsCounted) {
  SynthOptions o = Opts("plastic", "ring12", 32, Layout::kLp, 32);
  o.perturb.clip = 0.3;
  auto r = Synthesize(o);
  ASSERT_TRUE(r.ok());
  float mx = 0;
  int64_t at_clip = 0;
  for (int64_t i = 0; i < r->stack.plane_size() * 3 * 12; ++i) {
    mx = std::max(mx, r->stack.data()[i]);
    at_clip += r->stack.data()[i] == 0.3f;
  }
  EXPECT_EQ(mx, 0.3f);
  EXPECT_GT(r->perturb.clipped_samples, 0);
  EXPECT_EQ(at_clip, r->perturb.clipped_samples);
}

TEST(Synth, MisregistrationShiftsEachImage) {
  SynthOptions o = Opts("granite", "ring12", 48, Layout::kLp, 32);
  auto clean = Synthesize(o);
  o.perturb.misregister_px = 1.0;
  auto moved = Synthesize(o);
  ASSERT_TRUE(clean.ok() && moved.ok());
  for (int i = 0; i < 12; ++i) {
    const double sx = moved->perturb.shift_x[i], sy = moved->perturb.shift_y[i];
    EXPECT_LE(std::abs(sx), 1.0);
    EXPECT_LE(std::abs(sy), 1.0);
    // An interior texel of the shifted image is the bilinear sample of the clean one.
    const int x = 20, y = 21;
    const double px = x - sx, py = y - sy;
    const int x0 = int(std::floor(px)), y0 = int(std::floor(py));
    const double fx = px - x0, fy = py - y0;
    auto c = [&](int yy, int xx) { return double(clean->stack.At(i, 0, yy, xx)); };
    const double expected = (c(y0, x0) * (1 - fx) + c(y0, x0 + 1) * fx) * (1 - fy) +
                            (c(y0 + 1, x0) * (1 - fx) + c(y0 + 1, x0 + 1) * fx) * fy;
    EXPECT_NEAR(moved->stack.At(i, 0, y, x), expected, 1e-5);
  }
}

TEST(Synth, FabricsCastShadowsAtGrazingLightOnly) {
  auto r = Synthesize(Opts("corduroy", "bonn81", 64, Layout::kBonn, 16));
  ASSERT_TRUE(r.ok());
  auto dark_fraction = [&](int i) {
    int64_t dark = 0;
    for (float v : r->stack.Plane(i, 0)) dark += v == 0.0f;
    return double(dark) / double(r->stack.plane_size());
  };
  EXPECT_EQ(dark_fraction(0), 0.0);  // θl = 0: nothing is shadowed
  // θl = 75°, φ = 0 (across the ridges): the grooves are in shadow.
  EXPECT_GT(dark_fraction(81 - 24), 0.05);
}

TEST(Synth, ShadowVisibilityOnAStep) {
  // A wall of height 4 texels at x ≥ 10: light from +x at 45° shadows x in [6, 10).
  Image h(20, 3, 1, 0.0f);
  for (int y = 0; y < 3; ++y)
    for (int x = 10; x < 20; ++x) h.At(0, y, x) = 4.0f;
  const Image vis = CastShadowVisibility(h, Normalize(Vec3(1, 0, 1)));
  for (int x = 0; x < 20; ++x) {
    const bool shadowed = x >= 7 && x < 10;  // ray from x rises 1 per texel: blocked if 10 − x < 4
    EXPECT_EQ(vis.At(0, 1, x), shadowed ? 0.0f : 1.0f) << x;
  }
}

TEST(Synth, NormalsFromAPlanarHeightField) {
  Image h(8, 8, 1);
  for (int y = 0; y < 8; ++y)
    for (int x = 1; x < 7; ++x)
      h.At(0, y, x) = 0.5f * x - 0.25f * y;  // ∂h/∂x = 0.5, ∂h/∂y_up = 0.25
  const Image n = NormalsFromHeight(h);
  const Vec3 expected = Normalize(Vec3(-0.5, -0.25, 1));
  EXPECT_NEAR(n.At(0, 4, 3), expected.x, 1e-6);
  EXPECT_NEAR(n.At(1, 4, 3), expected.y, 1e-6);
  EXPECT_NEAR(n.At(2, 4, 3), expected.z, 1e-6);
}

TEST(Synth, EveryMaterialHasValidMaps) {
  for (const auto& m : Materials()) {
    auto maps = MakeMaterial(m.name, 32, 5);
    ASSERT_TRUE(maps.ok()) << m.name;
    for (int64_t i = 0; i < 32 * 32; ++i) {
      const Vec3 n(maps->normal.Plane(0)[i], maps->normal.Plane(1)[i], maps->normal.Plane(2)[i]);
      ASSERT_NEAR(Length(n), 1.0, 1e-5) << m.name;
      ASSERT_GT(n.z, 0.0) << m.name;
      for (int c = 0; c < 3; ++c) {
        ASSERT_GE(maps->albedo.Plane(c)[i], 0.0f) << m.name;
        ASSERT_LE(maps->albedo.Plane(c)[i], 1.0f) << m.name;
      }
    }
  }
  auto leaf = MakeMaterial("leaf", 64, 1);
  ASSERT_TRUE(leaf.ok());
  ASSERT_FALSE(leaf->thickness.empty());
  float tmax = 0;
  for (float t : leaf->thickness.data()) tmax = std::max(tmax, t);
  EXPECT_GT(tmax, 0.3f);  // the midrib is thicker than the blade (0.2 mm)
  EXPECT_LT(tmax, 0.7f);
}

TEST(Synth, WritesDatasetAndTruthAtomically) {
  TempDir tmp;
  const SynthOptions o = Opts("leaf", "ring12", 16, Layout::kLp, 16);
  auto r = Synthesize(o);
  ASSERT_TRUE(r.ok());
  ASSERT_TRUE(WriteSynthDataset(*r, o, tmp / "leaf", false).ok());
  for (const char* f :
       {"lights.lp", "img_011.png", "mask.png", "truth/params.json", "truth/normal.exr",
        "truth/normal.png", "truth/albedo.png", "truth/thickness.exr", "truth/translucency.exr"})
    EXPECT_TRUE(fs::exists(tmp / (std::string("leaf/") + f))) << f;
  std::ifstream pj(tmp / "leaf/truth/params.json");
  const auto j = nlohmann::json::parse(pj);
  EXPECT_EQ(j["material"]["name"], "leaf");
  EXPECT_EQ(j["model"]["name"], "cook-torrance");
  EXPECT_EQ(j["lights"].size(), 12u);
  // Existing output: refused without overwrite, nothing else left behind.
  Status again = WriteSynthDataset(*r, o, tmp / "leaf", false);
  EXPECT_FALSE(again.ok());
  EXPECT_NE(again.message().find("--force"), std::string::npos);
  int entries = 0;
  for (const auto& e : fs::directory_iterator(tmp.path())) ++entries, (void)e;
  EXPECT_EQ(entries, 1);
  EXPECT_TRUE(WriteSynthDataset(*r, o, tmp / "leaf", true).ok());
}

TEST(Synth, OptionsAreValidated) {
  SynthOptions o;
  std::string why;
  o.material = "velvet";
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("plaster"), std::string::npos);
  o = {};
  o.perturb.clip = 1.5;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("--clip"), std::string::npos);
  o = {};
  o.bits = 12;
  EXPECT_FALSE(o.Check(&why));
  o = {};
  o.size = 2;
  EXPECT_FALSE(o.Check(&why));
  o = {};
  EXPECT_TRUE(o.Check(&why));
}

// The committed fixtures are what the generator makes today (fixtures/generate.sh).
TEST(Fixtures, CommittedFixturesAreReproducible) {
  const std::string fixtures = std::string(MATFIT_SOURCE_DIR) + "/fixtures";
  const std::string dir = fixtures + "/plaster-bonn81";
  if (!fs::exists(dir)) GTEST_SKIP() << "fixtures not generated";
  auto committed = ReadDataset(dir);
  ASSERT_TRUE(committed.ok()) << committed.status().ToString();
  std::ifstream pj(dir + "/truth/params.json");
  const auto j = nlohmann::json::parse(pj);
  SynthOptions o = Opts(j["material"]["name"], j["light_set"], j["size"], Layout::kBonn, j["bits"]);
  o.seed = j["seed"];
  auto fresh = Synthesize(o);
  ASSERT_TRUE(fresh.ok());
  EXPECT_LE(matfit::testing::MaxAbsDiff(*committed, fresh->stack), 0.5 / 65535 + 1e-7);
}

}  // namespace
}  // namespace matfit::synth
