// matfit bench and the stability matrix: real properties of their results and stable schemas.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "eval/bench.h"
#include "eval/bench_charts.h"
#include "eval/stability.h"

namespace matfit::eval {
namespace {

using nlohmann::json;

std::set<std::string> Keys(const json& j) {
  std::set<std::string> k;
  for (const auto& [key, v] : j.items()) k.insert(key);
  return k;
}

// An interpolating model fits its own samples almost exactly, so its residuals say little about
// the directions between them; the bound's floor from rbf's leave-one-light-out interpolation
// error (MaterialMaps::interpolation_error) keeps every cell free of silent texels — without it
// the clean cell (rbf-srgb) and the leaf (rbf: a GGX highlight between bonn81's lights) had
// 100 % and 74 % at 32².
TEST(Stability, TheInterpolatingModelBoundsItsErrorBetweenLights) {
  StabilityOptions o;
  o.size = 32;
  o.methods = {"rbf", "rbf-srgb"};
  o.cases = {"clean", "leaf", "highlights", "noise-1%", "micro-geometry"};
  auto r = RunStability(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_EQ(r->cells.size(), 10u);
  for (const auto& c : r->cells) {
    ASSERT_TRUE(c.applicable && !c.refused) << c.method << " " << c.perturbation;
    EXPECT_EQ(c.silent, 0) << c.method << " fails silently on " << c.perturbation;
    EXPECT_LT(c.bound_ratio_median, 12) << c.method << " " << c.perturbation;
  }
}

TEST(Stability, NoSilentFailureOnAnyDegenerateCase) {
  StabilityOptions o;
  o.size = 16;
  o.methods = {"mean", "lambert", "lambert-robust", "ptm", "blinn-phong", "leaf-hl2"};
  auto r = RunStability(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_EQ(r->cells.size(), o.methods.size() * StabilityCases().size());
  std::map<std::string, bool> degenerate;
  for (const auto& c : StabilityCases()) degenerate[c.name] = c.degenerate;
  auto cell = [&](const std::string& m, const std::string& p) -> const StabilityCell& {
    for (const auto& c : r->cells)
      if (c.method == m && c.perturbation == p) return c;
    ADD_FAILURE() << m << " " << p;
    return r->cells[0];
  };
  for (const auto& c : r->cells) {
    if (!c.applicable || c.refused) continue;
    EXPECT_GT(c.texels, 0) << c.method << " " << c.perturbation;
    if (degenerate[c.perturbation]) {
      EXPECT_EQ(c.silent, 0) << c.method << " fails silently on " << c.perturbation;
    }
  }
  // The matrix measures what it says: clean Lambertian data is fitted near-exactly by lambert,
  // the gamma mistake and grazing-only lights are flagged, thin leaves are flagged.
  EXPECT_LT(cell("lambert", "clean").error_median, 1e-3);
  EXPECT_GT(cell("mean", "clean").error_median, 10 * cell("lambert", "clean").error_median);
  for (const char* m : {"lambert", "blinn-phong"}) {
    EXPECT_DOUBLE_EQ(cell(m, "gamma-8bit").flagged_fraction, 1.0) << m;
    EXPECT_DOUBLE_EQ(cell(m, "grazing-only").flagged_fraction, 1.0) << m;
    const auto& cop = cell(m, "coplanar");
    EXPECT_TRUE(cop.refused || cop.flagged_fraction == 1.0) << m;
  }
  EXPECT_GT(cell("leaf-hl2", "thin-leaf").flagged_fraction, 0.5);
  EXPECT_FALSE(cell("leaf-hl2", "clean").applicable);
  EXPECT_FALSE(cell("lambert", "thin-leaf").applicable);

  const json j = json::parse(StabilityJson(*r));
  EXPECT_EQ(j["schema"], "matfit.stability/1");
  EXPECT_EQ(Keys(j), (std::set<std::string>{"schema", "size", "methods", "perturbations", "cells",
                                            "seconds"}));
  EXPECT_EQ(
      Keys(j["cells"][0]),
      (std::set<std::string>{"method", "perturbation", "applicable", "refused", "error", "texels",
                             "error_median", "error_p95", "normal_mae_deg", "flagged_fraction",
                             "warnings", "silent_texels", "silent_fraction", "bound_median",
                             "bound_ratio_median", "bound_ratio_p90"}));
  const auto charts = StabilityCharts(*r);
  EXPECT_EQ(charts.size(), 2u);
  for (const auto& [name, svg] : charts) EXPECT_NE(svg.find("</svg>"), std::string::npos) << name;
}

TEST(Bench, QuickSuiteScoresEveryMethodOnEveryCase) {
  BenchOptions o;
  o.quick = true;
  o.methods = {"mean", "lambert"};
  o.shared_data = MATFIT_SHARED_DATA;
  auto r = RunBench(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  const bool real = std::filesystem::exists(std::string(MATFIT_SHARED_DATA) + "/psm/cat") &&
                    std::filesystem::exists(std::string(MATFIT_SHARED_DATA) + "/leaf-sheet");
  if (!real)
    std::printf("shared data absent: the real cases are skipped (%zu)\n", r->skipped.size());
  EXPECT_EQ(r->cases.size(), real ? 10u : 7u);
  ASSERT_EQ(r->points.size(), r->cases.size() * 2);
  for (size_t i = 0; i < r->points.size(); i += 2) {
    const BenchPoint& mean = r->points[i];
    const BenchPoint& lam = r->points[i + 1];
    ASSERT_EQ(mean.dataset, lam.dataset);
    EXPECT_TRUE(mean.ok && lam.ok) << lam.dataset << ": " << lam.error;
    EXPECT_GT(lam.fit_seconds, 0);
    EXPECT_GT(lam.render_ns_per_pixel, 0);
    EXPECT_EQ(lam.parameters, 5);
    // Shading beats a constant on every dataset, whichever error scores it.
    if (lam.relight_rmse) {
      EXPECT_LT(*lam.relight_rmse, *mean.relight_rmse) << lam.dataset;
      EXPECT_TRUE(lam.normal_mae_deg.has_value());
      EXPECT_TRUE(std::isnan(lam.loo_rmse)) << "leave-one-out is for the real cases";
    } else {
      EXPECT_LT(lam.heldout_rmse, mean.heldout_rmse) << lam.dataset;
      // Real cases: leave-one-out too, in linear RMSE and in 8-bit sRGB PSNR.
      EXPECT_LT(lam.loo_rmse, mean.loo_rmse) << lam.dataset;
      EXPECT_GT(lam.loo_psnr_srgb8_db, mean.loo_psnr_srgb8_db) << lam.dataset;
      EXPECT_GT(lam.loo_psnr_srgb8_db, 20.0) << lam.dataset;
      EXPECT_NEAR(lam.loo_psnr_db, -20 * std::log10(lam.loo_rmse), 1e-9) << lam.dataset;
      EXPECT_GT(lam.heldout_psnr_srgb8_db, 20.0) << lam.dataset;
      EXPECT_GT(lam.loo_bound_ratio_median, 1.0) << lam.dataset;  // a bound, not an estimate
      EXPECT_GE(lam.loo_bound_ratio_p90, lam.loo_bound_ratio_median) << lam.dataset;
    }
  }
  ASSERT_FALSE(r->hl2.empty());
  EXPECT_LT(r->hl2.back().mean_error_percent, 5.0);  // N_L 512 on the 4× relief leaf

  const json j = json::parse(BenchJson(*r));
  EXPECT_EQ(j["schema"], "matfit.bench/1");
  EXPECT_EQ(Keys(j),
            (std::set<std::string>{"schema", "cases", "skipped", "points", "multi_view", "hl2_leaf",
                                   "hl2", "holdout", "loo", "threads", "seconds"}));
  EXPECT_TRUE(j["multi_view"].empty()) << "--methods narrows the suite to the single-view cases";
  EXPECT_EQ(Keys(j["points"][0]), (std::set<std::string>{"method",
                                                         "dataset",
                                                         "ok",
                                                         "error",
                                                         "texels",
                                                         "images",
                                                         "parameters",
                                                         "bytes_per_texel",
                                                         "fit_seconds",
                                                         "texels_per_second",
                                                         "render_ns_per_pixel",
                                                         "deviation_percent",
                                                         "deviation_percent_by_theta",
                                                         "heldout_rmse",
                                                         "heldout_rmse_fitted_texels",
                                                         "heldout_deviation_percent",
                                                         "heldout_psnr_srgb8_db",
                                                         "loo_rmse",
                                                         "loo_psnr_db",
                                                         "loo_psnr_srgb8_db",
                                                         "loo_bound_ratio_median",
                                                         "loo_bound_ratio_p90",
                                                         "loo_bound_exceeded_fraction",
                                                         "normal_mae_deg",
                                                         "albedo_rmse",
                                                         "relight_rmse",
                                                         "flagged_texels",
                                                         "bound_median"}));
  const auto charts = BenchCharts(*r);
  for (const auto& c : r->cases) {
    EXPECT_TRUE(charts.count("pareto_" + c.name + ".svg")) << c.name;
    EXPECT_TRUE(charts.count("theta_" + c.name + ".svg")) << c.name;
  }
  EXPECT_TRUE(charts.count("hl2_directions.svg"));
}

TEST(Bench, CasesSelectsPartOfTheSuiteAndRejectsUnknownNames) {
  BenchOptions o;
  o.quick = true;
  o.methods = {"lambert"};
  o.cases = {"plaster-40"};
  o.shared_data = MATFIT_SHARED_DATA;
  auto r = RunBench(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  ASSERT_EQ(r->cases.size(), 1u);
  EXPECT_EQ(r->cases[0].name, "plaster-40");
  ASSERT_EQ(r->points.size(), 1u);
  o.cases = {"psm-grey"};
  std::string why;
  EXPECT_FALSE(o.Check(&why));
  EXPECT_NE(why.find("'psm-grey' is not a case"), std::string::npos) << why;
}

// Issue 17: the multi-view case scores every model over views on the same held-out views. On
// lacquer (Cook–Torrance with Fresnel, parallax and masking per view) the joint svbrdf predicts
// them best of all at 11 bytes per texel, so it heads the storage-vs-error Pareto front; the
// per-view models and per-view PCA, looking a held-out view up by its nearest fitted view, pay
// for the view they did not see (measured --quick: svbrdf 0.281, best other 0.464, PCA k=8
// 0.610 at 593 B).
TEST(Bench, MultiViewCaseChartsStorageAgainstHeldOutViewError) {
  BenchOptions o;
  o.quick = true;
  o.cases = {"lacquer-views-24"};
  auto r = RunBench(o);
  ASSERT_TRUE(r.ok()) << r.status().ToString();
  EXPECT_TRUE(r->points.empty());
  std::map<std::string, MultiViewPoint> by;
  for (const MultiViewPoint& p : r->multi_view) {
    EXPECT_TRUE(p.ok) << p.method << ": " << p.error;
    EXPECT_TRUE(std::isfinite(p.heldout_view_rmse) && p.heldout_view_rmse > 0) << p.method;
    by[p.method] = p;
  }
  for (const char* m : {"svbrdf", "per-view:lambert", "per-view:cook-torrance", "cook-torrance",
                        "pca-k1", "pca-k8"})
    ASSERT_TRUE(by.count(m)) << m;
  const double joint = by["svbrdf"].heldout_view_rmse;
  for (const auto& [name, p] : by)
    if (name != "svbrdf") {
      EXPECT_GT(p.heldout_view_rmse, 1.3 * joint) << name;
    }
  // Storage: a per-view model stores its base's bytes once per training view (19 of 25).
  EXPECT_EQ(by["per-view:lambert"].bytes_per_texel, 19 * by["lambert"].bytes_per_texel);
  EXPECT_LT(by["pca-k1"].bytes_per_texel, by["pca-k8"].bytes_per_texel);
  EXPECT_EQ(by["svbrdf"].bytes_per_texel, 11);
  ASSERT_TRUE(by["svbrdf"].normal_mae_deg);
  EXPECT_LT(*by["svbrdf"].normal_mae_deg, 1.0);
  const auto charts = BenchCharts(*r);
  ASSERT_TRUE(charts.count("views_lacquer-views-24.svg"));
  EXPECT_NE(charts.at("views_lacquer-views-24.svg").find("Pareto front"), std::string::npos);
  const json j = json::parse(BenchJson(*r));
  ASSERT_EQ(j["multi_view"].size(), r->multi_view.size());
  EXPECT_EQ(Keys(j["multi_view"][0]),
            (std::set<std::string>{"dataset", "method", "family", "k", "ok", "error",
                                   "bytes_per_texel", "heldout_view_rmse", "heldout_view_texel_rms",
                                   "heldout_view_rmse_by_theta", "fit_seconds", "texels_per_second",
                                   "normal_mae_deg"}));
}

}  // namespace
}  // namespace matfit::eval
