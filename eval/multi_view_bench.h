// `matfit bench` multi-view cases (issue 17): the models over the views of a synthetic BTF —
// the joint svbrdf, per-view:<model>, single-view models fitted to the most frontal view, and the
// per-view PCA at k components — scored on the same held-out views and charted as storage
// (bytes per texel) against held-out-view error, with the Pareto front.
#pragma once

#include <cmath>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/progress_fn.h"
#include "core/status.h"

namespace matfit::eval {

struct MultiViewCase {
  std::string name;  // e.g. "lacquer-views-48"
  std::string material = "lacquer", lights = "bonn81", views = "bonn81";
  int size = 48;
  int holdout_views = 8;  // whole views left out (ChooseHeldOutViews: spread over θv)
};

// What was fitted and how it predicts a held-out view:
//   joint     one set of maps for every view (svbrdf), evaluated at the held-out view;
//   per-view  a set per training view, the nearest one predicting (per-view:<model>);
//   frontal   a single-view model fitted to the most frontal view, evaluated at every view;
//   pca       per-view PCA with k components, the nearest training view's reconstruction.
struct MultiViewPoint {
  std::string dataset, method, family;
  int k = 0;  // pca: components
  bool ok = true;
  std::string error;               // when the method refused the case
  double bytes_per_texel = 0;      // as stored for the training views
  double heldout_view_rmse = NAN;  // pooled over every held-out sample
  // The mean over texels of each texel's RMS over its held-out samples: every texel weighs the
  // same (the pooled figure is led by the brightest, near-mirror samples of grazing views).
  double heldout_view_texel_rms = NAN;
  std::map<int, double> heldout_view_rmse_by_theta;  // pooled, per held-out θv (15° groups)
  double fit_seconds = NAN;  // the fit on the training views (median of the repeats); pca: none
  double texels_per_second = NAN;
  std::optional<double> normal_mae_deg;  // the fit's (most frontal) maps vs truth
};

// The suite's multi-view cases: quick one 24² BTF of 25 views; full 48² and 128² ones of 81
// views (Bonn's view set), 8 views held out.
std::vector<MultiViewCase> MultiViewSuite(bool quick);

// The models over views benchmarked by default (the per-view and frontal bases are a few of the
// ladder's; pca at ks).
struct MultiViewMethods {
  std::vector<std::string> joint = {"svbrdf"};
  std::vector<std::string> per_view = {"per-view:lambert", "per-view:heinrich",
                                       "per-view:cook-torrance"};
  std::vector<std::string> frontal = {"lambert", "heinrich", "blinn-phong", "cook-torrance"};
  std::vector<int> pca_ks = {1, 2, 4, 8};
};

// Synthesises the case (truth maps kept), fits each method on the training views and scores
// the held-out views. `progress` counts the methods done.
StatusOr<std::vector<MultiViewPoint>> RunMultiViewCase(const MultiViewCase& c,
                                                       const MultiViewMethods& methods, int repeats,
                                                       const ProgressFn& progress = {});

}  // namespace matfit::eval
