#include "eval/bench_charts.h"

#include <cmath>
#include <cstdio>
#include <set>

#include "eval/chart.h"

namespace matfit::eval {
namespace {

std::string Fmt(const char* f, double v) {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// The error a dataset is scored by: relighting RMSE against the truth on synthetic data, the
// held-out-light RMSE on real data.
double PointError(const BenchPoint& p, bool synthetic) {
  if (synthetic) return p.relight_rmse ? *p.relight_rmse : NAN;
  return p.heldout_rmse;
}

}  // namespace

std::map<std::string, std::string> BenchCharts(const BenchResult& r) {
  std::map<std::string, std::string> out;
  for (const BenchCase& c : r.cases) {
    const bool synthetic = !c.material.empty();
    XYChart xy;
    xy.title = c.name + ": fit time vs error (" + std::to_string(c.size) + "², " +
               (synthetic ? std::string("relighting error vs truth over a 48-light dome")
                          : "held-out-light error, " + std::to_string(r.holdout) + " folds") +
               ")";
    xy.x_label = "fit time (s, median, " + std::to_string(r.threads) + " threads)";
    xy.y_label = synthetic ? "relighting RMSE (linear radiance)" : "held-out RMSE (linear)";
    xy.log_x = xy.log_y = true;
    std::vector<double> xs, ys;
    XYChart theta;
    theta.title = c.name + ": reconstruction deviation per light elevation group";
    theta.x_label = "θ_l group (degrees)";
    theta.y_label = "deviation (%, METHODS.md §2)";
    theta.log_y = true;
    for (const BenchPoint& p : r.points) {
      if (p.dataset != c.name || !p.ok) continue;
      Series s;
      s.label = p.method + " (" + std::to_string(p.parameters) + " p, " +
                std::to_string(p.bytes_per_texel) + " B)";
      s.x = {p.fit_seconds};
      s.y = {PointError(p, synthetic)};
      s.point_labels = {p.method};
      xs.push_back(s.x[0]);
      ys.push_back(s.y[0]);
      xy.series.push_back(s);
      Series t;
      t.label = p.method;
      t.line = true;
      for (const auto& [g, d] : p.deviation_percent_by_theta) {
        t.x.push_back(g);
        t.y.push_back(d);
      }
      theta.series.push_back(t);
    }
    // ParetoFront skips nothing: map non-finite errors far away so they never join the front.
    std::vector<double> ysafe = ys;
    for (double& y : ysafe)
      if (!std::isfinite(y)) y = INFINITY;
    xy.pareto = ParetoFront(xs, ysafe);
    theta.x_ticks = {0, 15, 30, 45, 60, 75};
    out["pareto_" + c.name + ".svg"] = XYChartSvg(xy);
    out["theta_" + c.name + ".svg"] = XYChartSvg(theta);
  }
  // Multi-view cases: storage vs held-out-view error, one series per family.
  std::set<std::string> view_cases;
  for (const MultiViewPoint& p : r.multi_view) view_cases.insert(p.dataset);
  for (const std::string& name : view_cases)
    for (const bool per_texel : {false, true}) {
      XYChart v;
      v.title = name + ": storage vs held-out-view error (whole views left out" +
                (per_texel ? ", texel mean)" : ", pooled)");
      v.x_label = "bytes per texel (log; per-view models and PCA: every training view)";
      v.y_label = per_texel ? "mean over texels of the held-out RMS (linear, per unit light)"
                            : "held-out-view RMSE over every sample (linear, per unit light)";
      v.log_x = v.log_y = true;
      std::vector<double> xs, ys;
      for (const char* family : {"joint", "per-view", "frontal", "pca"}) {
        Series s;
        s.label = std::string(family) == "joint"      ? "joint over views (svbrdf)"
                  : std::string(family) == "per-view" ? "per view, nearest view predicts"
                  : std::string(family) == "frontal"  ? "frontal view's fit, every view"
                                                      : "per-view PCA, k components";
        s.line = std::string(family) == "pca";
        for (const MultiViewPoint& p : r.multi_view) {
          if (p.dataset != name || p.family != family || !p.ok) continue;
          const double e = per_texel ? p.heldout_view_texel_rms : p.heldout_view_rmse;
          s.x.push_back(p.bytes_per_texel);
          s.y.push_back(e);
          s.point_labels.push_back(p.method);
          xs.push_back(p.bytes_per_texel);
          ys.push_back(std::isfinite(e) ? e : INFINITY);
        }
        if (!s.x.empty()) v.series.push_back(s);
      }
      v.pareto = ParetoFront(xs, ys);
      out[std::string(per_texel ? "views_texel_" : "views_") + name + ".svg"] = XYChartSvg(v);
    }
  if (!r.hl2.empty()) {
    XYChart h;
    h.title = "Leaf HL2 precompute: error vs N_L (" + r.hl2_leaf + ")";
    h.x_label = "light directions N_L (log)";
    h.y_label = "HL2 vs multipole mean relative error (%)";
    h.log_x = true;
    const char* names[3] = {"light at π/2 (overhead)", "light at π/4", "light at π/8 (grazing)"};
    for (int e = 0; e < 3; ++e) {
      Series s;
      s.label = names[e];
      s.line = true;
      for (const auto& p : r.hl2)
        if (int(p.error_percent_by_elevation.size()) > e) {
          s.x.push_back(p.directions);
          s.y.push_back(p.error_percent_by_elevation[e]);
        }
      h.series.push_back(s);
    }
    Series m;
    m.label = "mean (labels: fast precompute time)";
    m.line = true;
    for (const auto& p : r.hl2) {
      m.x.push_back(p.directions);
      m.y.push_back(p.mean_error_percent);
      m.point_labels.push_back(Fmt("%.0f ms", 1e3 * p.precompute_seconds));
    }
    h.series.push_back(m);
    out["hl2_directions.svg"] = XYChartSvg(h);
  }
  return out;
}

std::map<std::string, std::string> StabilityCharts(const StabilityResult& r) {
  std::map<std::string, std::string> out;
  HeatMap e, s;
  e.rows = s.rows = r.methods;
  e.cols = s.cols = r.perturbations;
  e.row_label = s.row_label = "method";
  e.col_label = s.col_label = "perturbation";
  e.title = "Stability: median relighting error (colour); cell: error ×1000, flagged %";
  e.value_label = "median relighting RMSE (linear, log scale)";
  e.log_scale = true;
  e.vmin = 1e-3, e.vmax = 0.3;
  s.title = "Silent failures: ok texels whose error exceeds their own bound (target 0)";
  s.value_label = "silent texels (%)";
  s.vmin = 0, s.vmax = 5;
  e.cell_width = s.cell_width = 64;
  e.cell_height = s.cell_height = 34;
  for (const StabilityCell& c : r.cells) {
    if (!c.applicable) {
      e.values.push_back(NAN), s.values.push_back(NAN);
      e.cell_text.push_back(""), s.cell_text.push_back("");
      continue;
    }
    if (c.refused) {
      e.values.push_back(NAN), s.values.push_back(0);
      e.cell_text.push_back("refused"), s.cell_text.push_back("refused");
      continue;
    }
    e.values.push_back(c.error_median);
    e.cell_text.push_back(
        (std::isfinite(c.error_median) ? Fmt("%.3g", 1e3 * c.error_median) : "—") + "\n" +
        Fmt("%.0f%% fl", 100 * c.flagged_fraction));
    s.values.push_back(100 * c.silent_fraction);
    s.cell_text.push_back(Fmt("%.2g%%", 100 * c.silent_fraction));
  }
  out["stability_error.svg"] = HeatMapSvg(e);
  out["stability_silent.svg"] = HeatMapSvg(s);
  return out;
}

}  // namespace matfit::eval
