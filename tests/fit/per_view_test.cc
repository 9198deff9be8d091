// per-view:<model> (issue 17): each view of a multi-view BTF fitted on its own — the
// literature's baseline — scored with each image's own view's maps, held-out views predicted
// from the nearest fitted view, and the pack of one set of maps per view read back.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>

#include "core/dataset/dataset.h"
#include "core/image_io.h"
#include "core/pack/pack.h"
#include "core/pack/pack_reader.h"
#include "core/synth/synth.h"
#include "fit/fit_job.h"
#include "fit/holdout_views.h"
#include "fit/method.h"
#include "fit/methods.h"
#include "fit/metrics.h"
#include "fit/per_view_fit.h"
#include "fit/select.h"

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
  // A view folder that is a symlink out of the pack is refused, never read.
  const fs::path outside = fs::temp_directory_path() / "matfit_per_view_outside";
  fs::remove_all(outside);
  fs::rename(dir / "views" / "v000", outside);
  fs::create_directory_symlink(outside, dir / "views" / "v000");
  bad = ReadPack(dir.string());
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("views[0]"), std::string::npos) << bad.status().message();
  EXPECT_NE(bad.status().message().find("outside the pack"), std::string::npos)
      << bad.status().message();
  fs::remove_all(dir);
  fs::remove_all(outside);
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

// --components: the per-view PCA at the largest k stored in the pack (pca/: per view its
// weights and basis as float EXR, pca.json) reconstructs every sample of every view at the error
// the report gives for that k (the discarded eigenvalues), read back from the files alone.
TEST(PerViewPca, ThePackHoldsAModelThatReconstructsAtTheReportedError) {
  const fs::path tmp = fs::temp_directory_path() / "matfit_pca_pack";
  fs::remove_all(tmp);
  synth::SynthOptions so;
  so.material = "lacquer", so.lights = "bonn81", so.views = "dome:4", so.size = 12, so.bits = 32;
  auto d = synth::Synthesize(so);
  ASSERT_TRUE(d.ok());
  ASSERT_TRUE(synth::WriteSynthDataset(*d, so, (tmp / "btf").string(), false).ok());
  FitJobOptions o;
  o.input = (tmp / "btf").string();
  o.read.all_views = true;
  o.model = "per-view:lambert";
  o.pca_components = {1, 3};
  o.out = (tmp / "pack").string();
  auto r = RunFitJob(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_EQ(r->per_view_pca.size(), 2u);
  const double reported = r->per_view_pca[1].rmse;
  std::ifstream in(tmp / "pack" / "pca" / "pca.json");
  const nlohmann::json j = nlohmann::json::parse(in);
  ASSERT_EQ(j["k"], 3);
  ASSERT_EQ(j["views"].size(), 4u);
  ReadOptions ro;
  ro.all_views = true;
  auto stack = ReadDataset(o.input, ro);
  ASSERT_TRUE(stack.ok());
  const auto groups = ViewGroups(*stack);
  const int C = stack->channels();
  double sse = 0, n = 0;
  for (size_t v = 0; v < groups.size(); ++v) {
    const nlohmann::json& jv = j["views"][v];
    ASSERT_EQ(jv["lights"].size(), groups[v].size());
    ImageReadOptions linear;
    linear.color_space = ColorSpaceChoice::kLinear, linear.all_channels = true;
    auto w = ReadImage((tmp / "pack" / jv["weights"].get<std::string>()).string(), linear);
    auto b = ReadImage((tmp / "pack" / jv["basis"].get<std::string>()).string(), linear);
    ASSERT_TRUE(w.ok() && b.ok());
    ASSERT_EQ(w->channels(), 3);
    const int D = int(groups[v].size()) * C;
    ASSERT_EQ(b->width(), D);
    ASSERT_EQ(b->height(), 4);
    for (size_t a = 0; a < groups[v].size(); ++a)
      for (int c = 0; c < C; ++c) {
        const int i = groups[v][a];
        const double I = jv["lights"][a]["intensity"][c].get<double>();
        for (int64_t p = 0; p < stack->plane_size(); ++p) {
          double pred = b->Plane(0)[int(a) * C + c];
          for (int k = 0; k < 3; ++k)
            pred += w->Plane(k)[p] * b->Plane(0)[int64_t(k + 1) * D + int(a) * C + c];
          const double e = stack->Sample(i, c, p) / I - pred;
          sse += e * e, n += 1;
        }
      }
  }
  const double rmse = std::sqrt(sse / n);
  EXPECT_NEAR(rmse, reported, 1e-4 * reported)
      << "from the files " << rmse << ", reported " << reported;
  EXPECT_LT(reported, r->per_view_pca[0].rmse);  // 3 components hold more than 1
  fs::remove_all(tmp);
}

// --model auto on a BTF: only the views the scene shows are fitted (scene.json
// view_theta_max_deg), always the most frontal; one view left is a single-view stack.
TEST(SceneViews, KeepsTheViewsTheSceneShowsAndAlwaysTheFrontalOne) {
  const LightStack& s = Lacquer().stack;
  const auto groups = ViewGroups(s);
  SceneSpec scene;
  EXPECT_EQ(ScenesViews(s, scene).num_images(), s.num_images());  // default 90°: every view
  scene.view_theta_max_deg = 0;  // head-on only: dome:9's most frontal view is at 16°
  const LightStack front = ScenesViews(s, scene);
  EXPECT_FALSE(front.is_multi_view());
  EXPECT_EQ(front.num_images(), int(groups[size_t(MostFrontalView(s, groups))].size()));
  EXPECT_NEAR(front.view_theta_deg, 16, 0.5);
  scene.view_theta_max_deg = 40;
  const LightStack some = ScenesViews(s, scene);
  ASSERT_TRUE(some.is_multi_view());
  int expected = 0;
  for (const auto& g : groups) {
    double theta = 0, phi = 0;
    AnglesDegFromDirection(s.ViewOf(g[0]), &theta, &phi);
    expected += theta <= 40.5;
  }
  EXPECT_EQ(int(ViewGroups(some).size()), expected);
  EXPECT_LT(expected, 9);
  auto bad = ParseScene(R"({"view_theta_max_deg": 95})", "scene.json");
  ASSERT_FALSE(bad.ok());
  EXPECT_NE(bad.status().message().find("view_theta_max_deg"), std::string::npos);
}

}  // namespace
}  // namespace matfit::fit
