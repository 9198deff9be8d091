// per-view:<model> out of core (issue 17): a multi-view stack over the memory budget fitted one
// view at a time — each view read alone, fitted, scored and dropped — so peak memory is one
// view's images plus every view's maps. Each view's fit is the in-memory per-view fit's (a view's
// fit never sees the other views); held-out views are scored with the nearest other view's maps
// (the per-view fits of the training views are the ones made here).
#pragma once

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "fit/assess.h"
#include "fit/diagnostics.h"
#include "fit/fit_types.h"
#include "fit/holdout_views.h"
#include "fit/method.h"
#include "fit/metrics.h"

namespace matfit::fit {

struct StreamedPerView {
  FitResult fit;  // views, and the most frontal view's maps as its own
  ReconstructionMetrics reconstruction, reconstruction_common;
  std::map<int, std::map<int, double>> deviation_by_view_theta;
  std::optional<HeldOutViewMetrics> heldout_views;
  std::optional<ToneResolution> tone;  // --color-space auto: estimated on the most frontal view
  FitAssessment assessment;            // of the most frontal view's maps, from its images
  std::string read_encoding;           // of every view's images (DescribeReadEncoding)
};

// `shape`: the dataset's headers with every view (StreamedFit::Open). `method` a per-view method
// (fit/per_view_fit.h). `held`: views to score as held out (ChooseHeldOutViews), may be empty.
// progress counts views read (and held-out views scored).
StatusOr<StreamedPerView> FitPerViewOutOfCore(const std::string& input, const ReadOptions& read,
                                              const LightStack& shape, const FitMethod& method,
                                              const FitOptions& options,
                                              const std::vector<int>& held,
                                              const ProgressFn& progress);

}  // namespace matfit::fit
