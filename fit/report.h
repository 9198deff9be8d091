// report.json of a fit (keys are a contract, documented in docs/pack.md).
#pragma once

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "fit/assess.h"
#include "fit/fit_types.h"
#include "fit/holdout.h"
#include "fit/holdout_views.h"
#include "fit/metrics.h"
#include "fit/per_view_pca.h"

namespace matfit::fit {

// Wall seconds per stage of a job, in the order the stages ran (stages that did not run are
// absent), and the job's total so far.
struct StageTimings {
  std::vector<std::pair<std::string, double>> stages;
  double total = 0;
};

struct FitReportInputs {
  const FitResult* result = nullptr;
  int parameters_per_texel = 0, bytes_per_texel = 0;
  int images = 0;
  ReconstructionMetrics reconstruction;
  ReconstructionMetrics reconstruction_common;  // over the common texel set (fit/metrics.h)
  std::optional<HeldOutMetrics> heldout;
  std::optional<HeldOutViewMetrics> heldout_views;
  std::map<int, std::map<int, double>> deviation_by_view_theta;  // multi-view stacks
  std::vector<PcaPoint> per_view_pca;                            // --components
  std::optional<TruthMetrics> truth;
  const FitAssessment* assessment = nullptr;  // optional
  // How the images were linearised, and what --color-space auto changed (optional).
  const ToneResolution* tone = nullptr;
  std::string read_encoding;  // e.g. "linear (tone-curve estimate …)"
  // The bound's tightness (fit/confidence.h BoundToActualRatio) against held-out lights and
  // against truth, when those ran.
  std::optional<BoundRatio> bound_ratio_heldout, bound_ratio_truth;
  std::string selection_json;  // optional: SelectionJson (model auto)
  std::string source;
  const StageTimings* timings = nullptr;  // optional: report.json "timings"
  // --crop: the region of the source images that was fitted (report.json "crop"; null when
  // the whole images were).
  struct Region {
    int x = 0, y = 0, width = 0, height = 0, source_width = 0, source_height = 0;
  };
  std::optional<Region> crop;
};

std::string MakeReportJson(const FitReportInputs& in);

}  // namespace matfit::fit
