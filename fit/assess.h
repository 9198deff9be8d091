// The fit's own account of how far to trust it: stack diagnostics (fit/diagnostics.h) and the
// per-texel error bound (fit/confidence.h), applied to a finished fit. `matfit fit`, the
// server, the bench and the stability matrix all call this after FitMethod::Fit.
#pragma once

#include "fit/confidence.h"
#include "fit/diagnostics.h"
#include "fit/fit_types.h"
#include "fit/method.h"

namespace matfit::fit {

struct FitAssessment {
  Confidence confidence;
  StackDiagnostics diagnostics;
};

// Marks texels kTexelUnverifiable (no bound) and, when the stack looks gamma-encoded, every ok
// texel kTexelSuspectData (bound +inf); appends the warnings; recounts flagged_texels.
// `progress` follows the per-texel bound (the part that reads the stack).
// `residuals`: ScoreStack's sums for this fit (fit/score.h), when a fused pass made them.
// `diagnostics`: DiagnoseStack(stack), when the caller has it (the fit job's read made it).
FitAssessment AssessFit(const LightStack& stack, const FitMethod& method, FitResult* result,
                        const ConfidenceOptions& options = {}, const ProgressFn& progress = {},
                        const TexelResiduals* residuals = nullptr,
                        const StackDiagnostics* diagnostics = nullptr);

}  // namespace matfit::fit
