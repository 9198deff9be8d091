// report.json of a fit (keys are a contract, documented in docs/pack.md).
#pragma once

#include <optional>
#include <string>

#include "fit/assess.h"
#include "fit/fit_types.h"
#include "fit/holdout.h"
#include "fit/metrics.h"

namespace matfit::fit {

struct FitReportInputs {
  const FitResult* result = nullptr;
  int parameters_per_texel = 0, bytes_per_texel = 0;
  int images = 0;
  ReconstructionMetrics reconstruction;
  std::optional<HeldOutMetrics> heldout;
  std::optional<TruthMetrics> truth;
  const FitAssessment* assessment = nullptr;  // optional
  std::string selection_json;                 // optional: SelectionJson (model auto)
  std::string source;
};

std::string MakeReportJson(const FitReportInputs& in);

}  // namespace matfit::fit
