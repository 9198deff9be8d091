// Near (point) lights: light_positions.txt read and written, the texel frame kept through crops
// and mips, tiles within their tolerance, scoring exact per texel, and fits that recover the
// truth with positions where distant lights cannot (core/near_lights.h, fit/near_fit.h).
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>

#include "core/dataset/dataset.h"
#include "core/near_lights.h"
#include "core/stack_ops.h"
#include "fit/diagnostics.h"
#include "fit/holdout.h"
#include "fit/method.h"
#include "fit/metrics.h"
#include "fit/score.h"
#include "tests/fit/synth_data.h"

namespace matfit::fit {
namespace {

namespace fs = std::filesystem;

// A plaster-like material under 40 dome lights, each `distance` texels from the image centre.
synth::SynthResult NearData(const std::string& material, int size, double distance,
                            const std::string& lights = "dome:40") {
  synth::SynthOptions o;
  o.material = material, o.lights = lights, o.size = size;
  o.layout = Layout::kLp, o.bits = 32, o.near_lights = distance;
  auto r = synth::Synthesize(o);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? std::move(*r) : synth::SynthResult{};
}

// The same stack with its lights taken as distant (their nominal directions).
LightStack Distant(const LightStack& s) {
  LightStack out = s;
  for (LightSample& l : out.lights()) l.has_position = false;
  return out;
}

double Deg(const Vec3& a, const Vec3& b) {
  return std::acos(std::clamp(Dot(Normalize(a), Normalize(b)), -1.0, 1.0)) * 180 / M_PI;
}

TEST(NearLights, TheTexelFrameFollowsCropsAndMips) {
  LightStack s(16, 12, 1, 1);
  s.near_frame = {-7.5, 5.5, 1.0};
  auto crop = CropStack(s, 3, 2, 8, 6);
  ASSERT_TRUE(crop.ok());
  const Vec3 a = NearTexelPosition(*crop, 0, 0), b = NearTexelPosition(s, 3, 2);
  EXPECT_DOUBLE_EQ(a.x, b.x);
  EXPECT_DOUBLE_EQ(a.y, b.y);
  auto mip = DownsampleStack(s, 2);
  ASSERT_TRUE(mip.ok());
  // Block (1, 1) covers texels 2..3 × 2..3: its centre is their mean position.
  const Vec3 m = NearTexelPosition(*mip, 1, 1), c = NearTexelPosition(s, 2.5, 2.5);
  EXPECT_DOUBLE_EQ(m.x, c.x);
  EXPECT_DOUBLE_EQ(m.y, c.y);
  EXPECT_DOUBLE_EQ(mip->near_frame.step, 2.0);
}

TEST(NearLights, EveryTexelIsWithinItsTilesTolerance) {
  const synth::SynthResult r = NearData("plaster", 64, 600);
  const LightStack& s = r.stack;
  ASSERT_TRUE(s.has_light_positions());
  NearLightOptions o;
  const NearTilePlan plan = PlanNearTiles(s, o);
  ASSERT_GT(plan.tile, 0);
  EXPECT_LE(plan.max_direction_error_deg, o.max_direction_error_deg);
  EXPECT_LE(plan.max_falloff_error, o.max_falloff_error);
  // Every texel, every light: the plan's figures are the true worst case.
  double worst_dir = 0, worst_fall = 0;
  for (int y = 0; y < s.height(); ++y)
    for (int x = 0; x < s.width(); ++x) {
      const int tx = x / plan.tile, ty = y / plan.tile;
      const int x0 = tx * plan.tile, y0 = ty * plan.tile;
      const int w = std::min(s.width() - x0, plan.tile), h = std::min(s.height() - y0, plan.tile);
      const Vec3 c = NearTexelPosition(s, x0 + 0.5 * (w - 1), y0 + 0.5 * (h - 1));
      const Vec3 p = NearTexelPosition(s, x, y);
      for (const LightSample& l : s.lights()) {
        const LightSample own = LightSeenFrom(l, p), tile = LightSeenFrom(l, c);
        worst_dir = std::max(worst_dir, Deg(own.direction, tile.direction));
        worst_fall = std::max(worst_fall, std::abs(tile.intensity.x / own.intensity.x - 1));
      }
    }
  std::printf("tile %d: worst direction %.4f° (plan %.4f°), fall-off %.5f (plan %.5f)\n", plan.tile,
              worst_dir, plan.max_direction_error_deg, worst_fall, plan.max_falloff_error);
  EXPECT_LE(worst_dir, plan.max_direction_error_deg + 1e-9);
  EXPECT_LE(worst_fall, plan.max_falloff_error + 1e-9);
}

TEST(NearLights, ScoringEvaluatesEveryTexelUnderItsOwnLight) {
  const synth::SynthResult r = NearData("plaster", 48, 150);
  const std::vector<uint8_t> none;
  const double near = ScoreStack(r.stack, r.truth, none).reconstruction.rmse;
  const double distant = ScoreStack(Distant(r.stack), r.truth, none).reconstruction.rmse;
  std::printf("truth maps, reconstruction rmse: %.2e with positions, %.4f as distant lights\n",
              near, distant);
  EXPECT_LT(near, 1e-5);  // the renderer and the scorer agree by construction
  EXPECT_GT(distant, 0.01);
}

// One model fitted to a near-light stack twice: with the positions and as distant lights, each
// scored against the truth and on held-out lights (4 folds).
struct PositionsVsDistant {
  FitResult near, distant;
  TruthMetrics tn, td;
  HeldOutMetrics hn, hd;
};

PositionsVsDistant FitBoth(const std::string& method, const synth::SynthResult& r) {
  PositionsVsDistant o;
  const auto m = MakeMethod(method);
  auto near = m->Fit(r.stack, {});
  auto distant = m->Fit(Distant(r.stack), {});
  auto hn = HeldOut(*m, r.stack, 4, {});
  auto hd = HeldOut(*m, Distant(r.stack), 4, {});
  EXPECT_TRUE(near.ok() && distant.ok() && hn.ok() && hd.ok()) << method;
  if (!near.ok() || !distant.ok() || !hn.ok() || !hd.ok()) return o;
  o.near = std::move(*near), o.distant = std::move(*distant), o.hn = *hn, o.hd = *hd;
  o.tn = CompareToTruth(o.near.maps, r.truth, o.near.status);
  o.td = CompareToTruth(o.distant.maps, r.truth, o.distant.status);
  return o;
}

TEST(NearLights, LambertRecoversTheNormalsOnlyWithPositions) {
  const PositionsVsDistant f = FitBoth("lambert", NearData("plaster", 64, 600));
  std::printf(
      "lambert, lights 600 px away: normal MAE %.3f° with positions (tile %g, %g tiles), "
      "%.3f° as distant; held-out rmse %.5f vs %.5f\n",
      f.tn.normal_mae_deg, f.near.parameters.at("near_tile_texels"),
      f.near.parameters.at("near_tiles"), f.td.normal_mae_deg, f.hn.rmse, f.hd.rmse);
  EXPECT_LT(f.tn.normal_mae_deg, 0.3);
  EXPECT_GT(f.td.normal_mae_deg, 4 * f.tn.normal_mae_deg);
  EXPECT_LT(f.hn.rmse, 0.5 * f.hd.rmse);
  EXPECT_LE(f.near.parameters.at("near_max_direction_error_deg"), 0.25);
}

TEST(NearLights, LinearBasesAndRobustFitsUseThePositions) {
  const synth::SynthResult r = NearData("plaster", 48, 500);
  for (const std::string name : {"lambert-robust", "ptm", "hsh2", "mean"}) {
    const auto m = MakeMethod(name);
    auto hn = HeldOut(*m, r.stack, 4, {});
    auto hd = HeldOut(*m, Distant(r.stack), 4, {});
    ASSERT_TRUE(hn.ok()) << name << ": " << hn.status().ToString();
    ASSERT_TRUE(hd.ok());
    std::printf("%-15s held-out rmse %.5f with positions, %.5f as distant lights\n", name.c_str(),
                hn->rmse, hd->rmse);
    EXPECT_LT(hn->rmse, hd->rmse) << name;
  }
}

// A lobe model's one shape per material is estimated over every tile at once (two passes), not
// per tile: on glossy plastic (Blinn–Phong, e = 40) it comes back as the whole-stack fit's would.
TEST(NearLights, ALobeModelSharesOneShapeOverAllTiles) {
  const PositionsVsDistant f = FitBoth("blinn-phong", NearData("plastic", 48, 500));
  std::printf(
      "blinn-phong on plastic, lights 500 px away: exponent %.2f with positions, %.2f as "
      "distant (truth 40); normal MAE %.3f° vs %.3f°; held-out rmse %.5f vs %.5f\n",
      f.near.parameters.at("exponent"), f.distant.parameters.at("exponent"), f.tn.normal_mae_deg,
      f.td.normal_mae_deg, f.hn.rmse, f.hd.rmse);
  EXPECT_NEAR(f.near.parameters.at("exponent"), 40.0, 0.4);
  EXPECT_LT(f.tn.normal_mae_deg, 0.3);
  EXPECT_GT(f.td.normal_mae_deg, 4 * f.tn.normal_mae_deg);
  EXPECT_LT(f.hn.rmse, 0.5 * f.hd.rmse);
}

// The first pass fits every step-th tile across and down for a median over about
// lobe_shape_texels texels (tiles spread over the image); the second pass fits every tile.
TEST(NearLights, TheShapePassSamplesTilesSpreadOverTheImage) {
  const synth::SynthResult r = NearData("plastic", 48, 500);
  const auto m = MakeMethod("blinn-phong");
  FitOptions every, sampled;
  every.lobe_shape_texels = 0;
  sampled.lobe_shape_texels = 128;  // step ⌊√(2304 / 128)⌋ = 4
  auto a = m->Fit(r.stack, every);
  auto b = m->Fit(r.stack, sampled);
  ASSERT_TRUE(a.ok() && b.ok());
  const double tile = a->parameters.at("near_tile_texels");
  std::printf(
      "tiles of %g texels; shape from %g texels (every tile) and %g (sampled): exponent "
      "%.3f and %.3f (truth 40)\n",
      tile, a->parameters.at("lobe_shape_texels"), b->parameters.at("lobe_shape_texels"),
      a->parameters.at("exponent"), b->parameters.at("exponent"));
  EXPECT_EQ(a->parameters.at("lobe_shape_texels"), 48.0 * 48.0);
  // Every 4th tile of each 4 × 4 block: a sixteenth of the texels (whole tiles).
  EXPECT_NEAR(b->parameters.at("lobe_shape_texels"), 48.0 * 48.0 / 16, tile * tile * 12);
  EXPECT_NEAR(b->parameters.at("exponent"), a->parameters.at("exponent"),
              0.02 * a->parameters.at("exponent"));
  EXPECT_NEAR(b->parameters.at("exponent"), 40.0, 0.8);
  EXPECT_EQ(a->status, b->status);  // the second pass fits every tile
  const TruthMetrics ta = CompareToTruth(a->maps, r.truth, a->status);
  const TruthMetrics tb = CompareToTruth(b->maps, r.truth, b->status);
  EXPECT_LT(tb.normal_mae_deg, 0.3);
  EXPECT_NEAR(tb.normal_mae_deg, ta.normal_mae_deg, 0.02);
  // Without a lobe in the sampled tiles (their texels black here), the first pass fits every
  // tile, as with every tile sampled: the same shape from the other texels, the same fit.
  synth::SynthResult dark = NearData("plastic", 48, 500);
  const int W = dark.stack.width(), T = int(tile);
  auto sampled_tile = [&](int64_t p) { return p % W / T % 4 == 2 && p / W / T % 4 == 2; };
  for (int i = 0; i < dark.stack.num_images(); ++i)
    for (int c = 0; c < dark.stack.channels(); ++c) {
      std::span<float> plane = dark.stack.Plane(i, c);
      for (int64_t p = 0; p < dark.stack.plane_size(); ++p)
        if (sampled_tile(p)) plane[size_t(p)] = 0;
    }
  auto c = m->Fit(dark.stack, every);
  auto d = m->Fit(dark.stack, sampled);
  ASSERT_TRUE(c.ok() && d.ok());
  EXPECT_EQ(c->status, d->status);
  EXPECT_NE(d->status[size_t(W * 2 * T + 2 * T)], kTexelOk);  // a sampled tile's texel
  EXPECT_EQ(c->parameters.at("exponent"), d->parameters.at("exponent"));
  EXPECT_EQ(c->maps.normal.data(), d->maps.normal.data());
  EXPECT_EQ(c->parameters.at("lobe_shape_texels"), d->parameters.at("lobe_shape_texels"));

  // A mask that leaves one of the sampled tiles' texels (4 of the 32 the shape needs at least,
  // a quarter of 128): every tile too.
  synth::SynthResult holes = NearData("plastic", 48, 500);
  holes.stack.mask.assign(size_t(holes.stack.plane_size()), 1);
  for (int64_t p = 0; p < holes.stack.plane_size(); ++p)
    if (sampled_tile(p) && !(p % W / T == 2 && p / W / T == 2)) holes.stack.mask[size_t(p)] = 0;
  ASSERT_EQ(holes.stack.MaskedTexels(), 48 * 48 - 35 * T * T);  // step ⌊√(2164 / 128)⌋ = 4
  auto e = m->Fit(holes.stack, every);
  auto f = m->Fit(holes.stack, sampled);
  ASSERT_TRUE(e.ok() && f.ok());
  EXPECT_EQ(f->parameters.at("lobe_shape_texels"), double(holes.stack.MaskedTexels()));
  EXPECT_EQ(e->parameters.at("exponent"), f->parameters.at("exponent"));
  EXPECT_EQ(e->maps.normal.data(), f->maps.normal.data());
}

// The tone-curve check regresses each texel against its own lamps (direction and fall-off): a
// linear set lit from close by reads as linear, not as a power curve (γ̂ 1.26 when it used the
// nominal directions).
TEST(NearLights, TheToneCurveCheckSeesTheFalloff) {
  const synth::SynthResult r = NearData("plaster", 64, 150);
  const StackDiagnostics d = DiagnoseStack(r.stack);
  const StackDiagnostics far = DiagnoseStack(Distant(r.stack));
  std::printf("lamps 150 px from a 64 px sample: γ̂ %.3f with positions, %.3f as distant lights\n",
              d.encoding_exponent, far.encoding_exponent);
  EXPECT_NEAR(d.encoding_exponent, 1.0, 0.02);
  EXPECT_GT(std::abs(far.encoding_exponent - 1.0), 0.1);  // what the positions correct
}

// rbf (one light-basis table per fit) and heinrich (its specular reference is the light along
// the view, which a near lamp is only at the centre) say so and how to go on.
TEST(NearLights, ModelsThatCannotSaySo) {
  const synth::SynthResult r = NearData("plaster", 16, 300);
  for (const std::string name : {"rbf", "heinrich"}) {
    auto f = MakeMethod(name)->Fit(r.stack, {});
    ASSERT_FALSE(f.ok()) << name;
    EXPECT_NE(f.status().message().find("--distant-lights"), std::string::npos) << name;
  }
}

class TempDir {
 public:
  TempDir() : path_(fs::temp_directory_path() / ("matfit_near_" + std::to_string(getpid()))) {
    fs::remove_all(path_);
  }
  ~TempDir() { fs::remove_all(path_); }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

TEST(NearLights, PositionsRoundTripThroughTheDatasetFile) {
  synth::SynthOptions o;
  o.material = "plaster", o.lights = "dome:12", o.size = 24, o.layout = Layout::kLp;
  o.bits = 16, o.near_lights = 250;
  auto r = synth::Synthesize(o);
  ASSERT_TRUE(r.ok());
  TempDir tmp;
  const fs::path dir = tmp.path() / "set";
  ASSERT_TRUE(synth::WriteSynthDataset(*r, o, dir.string(), false).ok());
  ASSERT_TRUE(fs::exists(dir / "light_positions.txt"));
  auto s = ReadDataset(dir.string());
  ASSERT_TRUE(s.ok()) << s.status().ToString();
  ASSERT_TRUE(s->has_light_positions());
  for (int i = 0; i < s->num_images(); ++i) {
    const Vec3 p = s->lights()[size_t(i)].position, t = r->stack.lights()[size_t(i)].position;
    EXPECT_NEAR(Length(p - t), 0, 1e-5);
    EXPECT_NEAR(Deg(s->lights()[size_t(i)].direction, t), 0, 1e-6);
  }
  // Texel (0, 0) of a 24 × 24 image: half a pixel in from the top-left corner.
  EXPECT_DOUBLE_EQ(s->near_frame.x0, -11.5);
  EXPECT_DOUBLE_EQ(s->near_frame.y0, 11.5);
  ReadOptions distant;
  distant.distant_lights = true;
  auto d = ReadDataset(dir.string(), distant);
  ASSERT_TRUE(d.ok());
  EXPECT_FALSE(d->has_light_positions());
  // --crop: the texels keep their place among the lights.
  ReadOptions crop;
  crop.crop = CropRect{5, 3, 10, 8};
  auto c = ReadDataset(dir.string(), crop);
  ASSERT_TRUE(c.ok()) << c.status().ToString();
  EXPECT_DOUBLE_EQ(c->near_frame.x0, -11.5 + 5);
  EXPECT_DOUBLE_EQ(c->near_frame.y0, 11.5 - 3);

  // A lights-txt set whose lights.txt (and positions) lie in the parent folder, as the psm sets
  // share theirs.
  synth::SynthOptions t = o;
  t.layout = Layout::kLightsTxt;
  const fs::path shared = tmp.path() / "shared", obj = shared / "obj";
  fs::create_directories(shared);
  ASSERT_TRUE(synth::WriteSynthDataset(*r, t, obj.string(), false).ok());
  fs::rename(obj / "lights.txt", shared / "lights.txt");
  fs::rename(obj / "light_positions.txt", shared / "light_positions.txt");
  auto parent = ReadDataset(obj.string());
  ASSERT_TRUE(parent.ok()) << parent.status().ToString();
  EXPECT_TRUE(parent->has_light_positions());

  // A wrong count and a light below the sample are refused, naming the file.
  auto rewrite = [&](const std::string& text) {
    std::ofstream(dir / "light_positions.txt") << text;
    return ReadDataset(dir.string());
  };
  auto bad = rewrite("3\n0 0 100\n0 0 100\n0 0 100\n");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("light_positions.txt"), std::string::npos);
  EXPECT_NE(bad.status().message().find("12 images"), std::string::npos);
  std::string below = "12\n";
  for (int i = 0; i < 12; ++i) below += i == 7 ? "10 10 -5\n" : "0 0 100\n";
  bad = rewrite(below);
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("light 7"), std::string::npos);
  bad = rewrite("12\n0 0 x\n");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("light_positions.txt"), std::string::npos);
}

}  // namespace
}  // namespace matfit::fit
