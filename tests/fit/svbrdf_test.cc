// svbrdf (issue 17): the Cook–Torrance SVBRDF fitted over every view × light of a synthetic
// multi-view BTF rendered rectified with parallax, masking and cast shadows (render_views.h).
// The truth is lacquer: F0 and roughness vary per texel, so the frontal start (one roughness
// per material) is not the answer.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "core/synth/synth.h"
#include "fit/method.h"
#include "fit/methods.h"
#include "fit/metrics.h"
#include "fit/per_view_pca.h"

namespace matfit::fit {
namespace {

synth::SynthResult MultiViewLacquer(int size, const std::string& views) {
  synth::SynthOptions o;
  o.material = "lacquer";
  o.lights = "bonn81";
  o.views = views;
  o.size = size;
  o.layout = Layout::kBonn;
  o.bits = 32;
  auto r = synth::Synthesize(o);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return std::move(*r);
}

double Median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double MeanFinite(const std::vector<float>& v) {
  double s = 0;
  int64_t n = 0;
  for (float x : v)
    if (std::isfinite(x)) s += x, ++n;
  return n ? s / double(n) : NAN;
}

TEST(Svbrdf, RecoversNormalF0AndRoughnessPerTexelAcrossViews) {
  const synth::SynthResult d = MultiViewLacquer(32, "dome:25");
  ASSERT_TRUE(d.stack.is_multi_view());
  auto fit = FitSvbrdf(d.stack, {});
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_EQ(fit->flagged_texels, 0);
  EXPECT_EQ(fit->maps.model, ShadingModel::kCookTorrance);
  const TruthMetrics t = CompareToTruth(fit->maps, d.truth, fit->status);
  std::vector<double> f0_rel, r_rel;
  for (int64_t p = 0; p < 32 * 32; ++p) {
    f0_rel.push_back(std::abs(fit->maps.specular.data()[p] / d.truth.specular.data()[p] - 1));
    r_rel.push_back(std::abs(fit->maps.roughness.data()[p] / d.truth.roughness.data()[p] - 1));
  }
  const double f0_med = Median(f0_rel), r_med = Median(r_rel);
  std::printf(
      "svbrdf, lacquer 32^2, 25 views x 81 lights: normal MAE %.3f deg, albedo RMSE %.4f, "
      "F0 median rel. error %.3f, roughness %.3f, start roughness %.3f\n",
      t.normal_mae_deg, t.albedo_rmse, f0_med, r_med, fit->parameters.at("start_roughness"));
  EXPECT_LE(t.normal_mae_deg, 1.0);
  EXPECT_LE(t.albedo_rmse, 0.02);
  EXPECT_LE(f0_med, 0.10);
  EXPECT_LE(r_med, 0.10);
  // The start (one roughness for the material) is not the answer: the truth spans 0.2–0.5.
  std::vector<double> start_rel;
  for (int64_t p = 0; p < 32 * 32; ++p)
    start_rel.push_back(
        std::abs(fit->parameters.at("start_roughness") / d.truth.roughness.data()[p] - 1));
  EXPECT_GT(Median(start_rel), 2 * r_med);
}

TEST(Svbrdf, PredictsHeldOutViewsBetterThanAnyFrontalOnlyModel) {
  const synth::SynthResult d = MultiViewLacquer(24, "dome:25");
  const auto groups = ViewGroups(d.stack);
  ASSERT_EQ(groups.size(), 25u);
  const int frontal = MostFrontalView(d.stack, groups);
  // Every fourth view held out (never the frontal one).
  std::vector<int> train, test;
  int held = 0;
  for (size_t g = 0; g < groups.size(); ++g) {
    const bool out = g % 4 == 1 && int(g) != frontal;
    held += out;
    for (int i : groups[g]) (out ? test : train).push_back(i);
  }
  ASSERT_GE(held, 5);
  const LightStack train_stack = SelectImages(d.stack, train);
  const LightStack test_stack = SelectImages(d.stack, test);
  auto joint = FitSvbrdf(train_stack, {});
  ASSERT_TRUE(joint.ok()) << joint.status().ToString();
  const double joint_err = MeanFinite(RelightingError(joint->maps, test_stack));

  // Frontal-only: every model of the single-view ladder on the frontal view, drawn at the
  // held-out views with its own formula (a view-independent model draws the frontal look).
  LightStack front = SelectImages(d.stack, groups[size_t(frontal)]);
  ASSERT_FALSE(front.is_multi_view());
  front.view_direction = d.stack.ViewOf(groups[size_t(frontal)][0]);
  double best = INFINITY;
  std::string best_name;
  for (const char* name :
       {"lambert", "lambert-robust", "blinn-phong", "cook-torrance", "ptm", "hsh3", "lafortune1"}) {
    auto f = MakeMethod(name)->Fit(front, {});
    ASSERT_TRUE(f.ok()) << name << ": " << f.status().ToString();
    const double e = MeanFinite(RelightingError(f->maps, test_stack));
    std::printf("held-out views (%d of 25): frontal-only %-14s %.5f\n", held, name, e);
    if (e < best) best = e, best_name = name;
  }
  std::printf("held-out views: svbrdf %.5f, best frontal-only (%s) %.5f, ratio %.2f\n", joint_err,
              best_name.c_str(), best, best / joint_err);
  EXPECT_LE(2 * joint_err, best);
}

TEST(Svbrdf, StartsFromTheMaterialsRoughnessWhenTheFirstTexelIsMasked) {
  synth::SynthResult d = MultiViewLacquer(16, "dome:9");
  d.stack.mask.assign(16 * 16, 1);
  for (int x = 0; x < 16; ++x) d.stack.mask[size_t(x)] = 0;  // the first row outside the sample
  auto fit = FitSvbrdf(d.stack, {});
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  EXPECT_EQ(fit->status[0], kTexelMasked);
  // The start is the material's roughness (0.2–0.5 truth), not the masked texel's 0.
  EXPECT_GT(fit->parameters.at("start_roughness"), 0.2);
  std::vector<double> r_rel;
  for (int64_t p = 16; p < 16 * 16; ++p)
    r_rel.push_back(std::abs(fit->maps.roughness.data()[p] / d.truth.roughness.data()[p] - 1));
  EXPECT_LE(Median(r_rel), 0.10);
}

// Per-view PCA (the data-driven reference): a Lambertian field over lights is ρ_c (n·l) per
// sample, so per view it spans (ρ_c) ⊗ (l_x, l_y, l_z) — rank ≤ 6 for plaster, whose albedo is a
// fixed colour plus one grey variation — and 6 components hold it exactly; fewer lose energy in
// order, and the storage grows with k.
TEST(Svbrdf, PerViewPcaHoldsALambertianFieldInSixComponents) {
  synth::SynthOptions o;
  o.material = "plaster", o.lights = "dome:30", o.views = "dome:4", o.size = 24;
  o.layout = Layout::kBonn, o.bits = 32;
  auto d = synth::Synthesize(o);
  ASSERT_TRUE(d.ok());
  const auto curve = PerViewPcaCurve(d->stack, {1, 2, 3, 6, 90});
  ASSERT_EQ(curve.size(), 5u);
  double rms = 0;  // of the samples themselves
  for (int i = 0; i < d->stack.num_images(); ++i)
    for (float v : d->stack.Plane(i, 1)) rms += double(v) * v;
  rms = std::sqrt(rms / (double(d->stack.num_images()) * 24 * 24));
  for (size_t q = 1; q < curve.size(); ++q) {
    EXPECT_LE(curve[q].rmse, curve[q - 1].rmse + 1e-12);
    EXPECT_GT(curve[q].bytes_per_texel, curve[q - 1].bytes_per_texel);
  }
  EXPECT_GT(curve[0].rmse, 1e-3 * rms);
  EXPECT_LT(curve[3].rmse, 1e-5 * rms) << "k = 6";
  EXPECT_LT(curve[4].rmse, 1e-6 * rms) << "k = every dimension";
  // 4 views × k half floats per texel, plus the shared vectors (4 views × (1 + k) × 90 floats
  // over 576 texels).
  EXPECT_NEAR(curve[0].bytes_per_texel, 4 * 2 + 4.0 * 4 * 2 * 90 / 576, 1e-9);
}

TEST(Svbrdf, SingleViewMethodsRefuseAMultiViewStackAndSayWhatToDo) {
  const synth::SynthResult d = MultiViewLacquer(8, "dome:3");
  auto f = MakeMethod("lambert")->Fit(d.stack, {});
  ASSERT_FALSE(f.ok());
  const std::string msg(f.status().message());
  EXPECT_NE(msg.find("3 views"), std::string::npos) << msg;
  EXPECT_NE(msg.find("--view"), std::string::npos) << msg;
  EXPECT_NE(msg.find("svbrdf"), std::string::npos) << msg;
  EXPECT_TRUE(MakeMethod("svbrdf")->Fit(d.stack, {}).ok());
}

}  // namespace
}  // namespace matfit::fit
