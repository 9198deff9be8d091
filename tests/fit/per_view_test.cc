// per-view:<model> (issue 17): each view of a multi-view BTF fitted on its own — the
// literature's baseline — scored with each image's own view's maps, held-out views predicted
// from the nearest fitted view, and the pack of one set of maps per view read back.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>

#include "core/pack/pack.h"
#include "core/pack/pack_reader.h"
#include "core/synth/synth.h"
#include "fit/holdout_views.h"
#include "fit/method.h"
#include "fit/methods.h"
#include "fit/metrics.h"
#include "fit/per_view_fit.h"

namespace matfit::fit {
namespace {

namespace fs = std::filesystem;

const synth::SynthResult& Lacquer() {  // 16², 9 views × 81 lights, rendered with parallax
  static const synth::SynthResult d = [] {
    synth::SynthOptions o;
    o.material = "lacquer";
    o.lights = "bonn81";
    o.views = "dome:9";
    o.size = 16;
    o.layout = Layout::kBonn;
    o.bits = 32;
    auto r = synth::Synthesize(o);
    EXPECT_TRUE(r.ok()) << r.status().ToString();
    return std::move(*r);
  }();
  return d;
}

void ExpectSameImage(const Image& a, const Image& b, const char* what) {
  ASSERT_EQ(a.channels(), b.channels()) << what;
  ASSERT_EQ(a.data().size(), b.data().size()) << what;
  for (size_t i = 0; i < a.data().size(); ++i)
    if (!(a.data()[i] == b.data()[i] || (std::isnan(a.data()[i]) && std::isnan(b.data()[i]))))
      FAIL() << what << " differs at " << i << ": " << a.data()[i] << " vs " << b.data()[i];
}

TEST(PerView, EachViewIsTheBaseModelFittedToThatViewAlone) {
  const LightStack& s = Lacquer().stack;
  const auto groups = ViewGroups(s);
  ASSERT_EQ(groups.size(), 9u);
  for (const char* base : {"lambert", "heinrich"}) {
    const auto method = MakeMethod(std::string("per-view:") + base);
    ASSERT_TRUE(method) << base;
    EXPECT_EQ(method->name(), std::string("per-view:") + base);
    auto fit = method->Fit(s, {});
    ASSERT_TRUE(fit.ok()) << fit.status().ToString();
    ASSERT_EQ(fit->views.size(), groups.size());
    EXPECT_EQ(fit->frontal_view, MostFrontalView(s, groups));
    EXPECT_EQ(fit->parameters.at("views"), 9);
    for (size_t g = 0; g < groups.size(); ++g) {
      const LightStack one = SelectView(s, groups[g]);
      ASSERT_FALSE(one.is_multi_view());
      auto alone = MakeMethod(base)->Fit(one, {});
      ASSERT_TRUE(alone.ok()) << alone.status().ToString();
      const ViewFit& v = fit->views[g];
      EXPECT_NEAR(Dot(v.view, s.ViewOf(groups[g][0])), 1.0, 1e-12);
      EXPECT_EQ(v.theta_deg, s.lights()[size_t(groups[g][0])].view_theta_deg);
      ExpectSameImage(v.maps.normal, alone->maps.normal, "normal");
      ExpectSameImage(v.maps.albedo, alone->maps.albedo, "albedo");
      EXPECT_EQ(v.status, alone->status);
    }
    // The fit's own maps are the most frontal view's.
    ExpectSameImage(fit->maps.normal, fit->views[size_t(fit->frontal_view)].maps.normal, "front");
  }
}

TEST(PerView, ScoresEveryImageWithItsOwnViewsMaps) {
  const LightStack& s = Lacquer().stack;
  const auto groups = ViewGroups(s);
  auto fit = MakeMethod("per-view:lambert")->Fit(s, {});
  ASSERT_TRUE(fit.ok()) << fit.status().ToString();
  const ReconstructionMetrics all = ScoreFit(s, *fit, false).reconstruction;
  // The same figure, view by view: Σ MSE · samples over the views.
  double sse = 0, n = 0;
  for (size_t g = 0; g < groups.size(); ++g) {
    const ReconstructionMetrics m =
        Reconstruction(SelectView(s, groups[g]), fit->views[g].maps, fit->views[g].status);
    sse += m.rmse * m.rmse * double(m.samples), n += double(m.samples);
  }
  EXPECT_EQ(all.samples, int64_t(n));
  EXPECT_NEAR(all.rmse, std::sqrt(sse / n), 1e-9 * all.rmse);
  // The frontal view's maps alone predict the oblique views worse than their own maps do
  // (lacquer: 0.313 vs 0.302; the lobe, which lambert cannot hold, dominates both).
  FitResult front_only = *fit;
  front_only.views.clear();
  const ReconstructionMetrics one = ScoreFit(s, front_only, false).reconstruction;
  EXPECT_GT(one.rmse, all.rmse * 1.02) << "frontal maps " << one.rmse << ", per view " << all.rmse;
  // dev% by (θv, θl): every view's images with their own maps.
  const auto by_view = DeviationByViewTheta(s, *fit);
  EXPECT_GE(by_view.size(), 2u);
}

TEST(PerView, PredictsAHeldOutViewFromTheNearestFittedView) {
  const LightStack& s = Lacquer().stack;
  const auto groups = ViewGroups(s);
  const auto method = MakeMethod("per-view:lambert");
  auto h = HeldOutViews(*method, s, 2, {});
  ASSERT_TRUE(h.ok()) << h.status().ToString();
  ASSERT_EQ(h->views.size(), 2u);
  EXPECT_EQ(h->train_views, 7);
  // By hand: fit the other views, predict each held-out view with the largest-cosine one.
  const std::vector<int> held = ChooseHeldOutViews(s, groups, 2);
  std::vector<int> train;
  for (size_t g = 0; g < groups.size(); ++g)
    if (std::find(held.begin(), held.end(), int(g)) == held.end())
      train.insert(train.end(), groups[g].begin(), groups[g].end());
  std::sort(train.begin(), train.end());
  auto fit = method->Fit(SelectImages(s, train), {});
  ASSERT_TRUE(fit.ok());
  for (const HeldOutView& hv : h->views) {
    int g = 0;
    while (s.lights()[size_t(groups[size_t(g)][0])].view_theta_deg != hv.theta_deg ||
           s.lights()[size_t(groups[size_t(g)][0])].view_phi_deg != hv.phi_deg)
      ++g;
    const Vec3 view = s.ViewOf(groups[size_t(g)][0]);
    size_t best = 0;
    for (size_t v = 1; v < fit->views.size(); ++v)
      if (Dot(fit->views[v].view, view) > Dot(fit->views[best].view, view)) best = v;
    const ReconstructionMetrics m = Reconstruction(SelectView(s, groups[size_t(g)]),
                                                   fit->views[best].maps, fit->views[best].status);
    EXPECT_NEAR(hv.metrics.rmse, m.rmse, 1e-9 * m.rmse) << hv.theta_deg << "," << hv.phi_deg;
  }
}

TEST(PerView, PackHoldsEveryViewAndReadsBack) {
  const LightStack& s = Lacquer().stack;
  auto fit = MakeMethod("per-view:lambert")->Fit(s, {});
  ASSERT_TRUE(fit.ok());
  const fs::path dir = fs::temp_directory_path() / "matfit_per_view_pack";
  fs::remove_all(dir);
  PackInfo info;
  info.method = fit->method;
  for (const ViewFit& v : fit->views)
    info.views.push_back({v.theta_deg, v.phi_deg, &v.maps, &v.status});
  ASSERT_TRUE(WritePack(fit->maps, fit->status, info, {}, dir.string()).ok());
  auto back = ReadPack(dir.string());
  ASSERT_TRUE(back.ok()) << back.status().ToString();
  ASSERT_EQ(back->views.size(), fit->views.size());
  EXPECT_EQ(back->method, "per-view:lambert");
  for (size_t v = 0; v < fit->views.size(); ++v) {
    EXPECT_EQ(back->views[v].theta_deg, fit->views[v].theta_deg);
    EXPECT_EQ(back->views[v].phi_deg, fit->views[v].phi_deg);
    ExpectSameImage(back->views[v].maps.normal, fit->views[v].maps.normal, "normal (exr)");
    ExpectSameImage(back->views[v].maps.albedo, fit->views[v].maps.albedo, "albedo (exr)");
    EXPECT_EQ(back->views[v].status, fit->views[v].status);
    EXPECT_EQ(NearestPackView(*back, fit->views[v].theta_deg, fit->views[v].phi_deg), int(v));
  }
  // A view's pack that lists views of its own is refused, naming the field.
  const fs::path inner = dir / "views" / "v001" / "material.json";
  std::string text;
  {
    std::ifstream in(inner);
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  const size_t at = text.find("\"views\": null");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 13, "\"views\": [{\"theta_deg\": 0, \"phi_deg\": 0, \"pack\": \"..\"}]");
  std::ofstream(inner) << text;
  auto bad = ReadPack(dir.string());
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("views[1]"), std::string::npos) << bad.status().message();
  fs::remove_all(dir);
}

TEST(PerView, OnlyTheLaddersModelsHaveAPerViewForm) {
  EXPECT_FALSE(MakeMethod("per-view:svbrdf"));
  EXPECT_FALSE(MakeMethod("per-view:per-view:lambert"));
  EXPECT_FALSE(MakeMethod("per-view:nope"));
  EXPECT_EQ(PerViewMethodNames().size(), MethodNames().size());
  for (const std::string& n : PerViewMethodNames()) {
    const auto m = MakeMethod(n);
    ASSERT_TRUE(m) << n;
    ASSERT_TRUE(PerViewBase(*m)) << n;
    EXPECT_EQ(m->bytes_per_texel(), PerViewBase(*m)->bytes_per_texel());
  }
  // A single-view method names the per-view form in its refusal.
  auto r = MakeMethod("heinrich")->Fit(Lacquer().stack, {});
  ASSERT_FALSE(r.ok());
  EXPECT_NE(r.status().message().find("per-view:heinrich"), std::string::npos)
      << r.status().message();
}

}  // namespace
}  // namespace matfit::fit
