#include "fit/assess.h"

#include <algorithm>
#include <cstdio>
#include <limits>

#include "core/stack_band.h"
#include "core/warnings.h"
#include "fit/fit_common.h"
#include "fit/light_cover.h"

namespace matfit::fit {

FitAssessment AssessFit(const LightStack& stack, const FitMethod& method, FitResult* r,
                        const ConfidenceOptions& options, const ProgressFn& progress,
                        const TexelResiduals* residuals, const StackDiagnostics* diagnostics) {
  FitAssessment a;
  a.diagnostics = diagnostics ? *diagnostics : DiagnoseStack(stack);
  a.confidence = ComputeConfidence(
      stack, r->maps,
      {method.parameters_per_texel(), method.parameters_per_channel(), method.light_parameters()},
      &r->status, options, progress, residuals);
  if (a.diagnostics.looks_gamma_encoded) {
    for (size_t p = 0; p < r->status.size(); ++p)
      if (r->status[p] == kTexelOk) {
        r->status[p] = kTexelSuspectData;
        a.confidence.bound[p] = std::numeric_limits<float>::infinity();
      }
  }
  for (const auto& w : a.diagnostics.warnings) r->warnings.push_back(w);
  // A model the lights cannot support matches the images it was fitted to and says nothing about
  // other directions: no texel can claim a bound (psm cat, hsh3, leave-one-out: 13 % of its texels
  // exceeded the bound they would otherwise have claimed).
  const std::string cover = LightCoverShortfall(stack.lights(), method);
  if (!cover.empty()) {
    r->warnings.push_back(Warning(WarningCode::kOverfitRisk, cover));
    for (size_t p = 0; p < r->status.size(); ++p)
      if (r->status[p] == kTexelOk) {
        r->status[p] = kTexelUnverifiable;
        a.confidence.bound[p] = std::numeric_limits<float>::infinity();
        ++a.confidence.unverifiable;
      }
  }
  if (a.diagnostics.looks_gamma_encoded || !cover.empty()) a.confidence.saturated = 0;  // no bound
  SumOverBands(stack, &a.confidence.unverifiable, 1);  // the whole stack's count
  SumOverBands(stack, &a.confidence.saturated, 1);
  if (a.confidence.unverifiable > 0) {
    char why[400];
    std::snprintf(why, sizeof why,
                  "%lld texel(s) cannot bound their error and are marked 'error cannot be "
                  "bounded': %s",
                  (long long)a.confidence.unverifiable,
                  !cover.empty() ? "the lights cannot support the model (see 'overfit-risk')"
                  : !a.confidence.frontal_covered
                      ? "no light lies within the frontal cone of the sample (add lights nearer "
                        "the camera axis)"
                  : !std::isfinite(a.confidence.extrapolation)
                      ? "the lights cannot predict other directions (nearly coplanar or "
                        "one-sided)"
                      : "fewer usable lights than the model's light parameters + 3 (add "
                        "lights or use a smaller model)");
    r->warnings.push_back(Warning(WarningCode::kUnboundedError, why));
  }
  // The fit's own "N texel(s) flagged" summary is stale now: count again.
  ResummariseStatus(r, &stack);  // the whole stack's count when it is a band
  return a;
}

}  // namespace matfit::fit
