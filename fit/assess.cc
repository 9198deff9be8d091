#include "fit/assess.h"

#include <limits>

namespace matfit::fit {

FitAssessment AssessFit(const LightStack& stack, const FitMethod& method, FitResult* r,
                        const ConfidenceOptions& options) {
  FitAssessment a;
  a.diagnostics = DiagnoseStack(stack);
  a.confidence = ComputeConfidence(
      stack, r->maps, {method.parameters_per_texel(), method.light_parameters()}, &r->status,
      options);
  if (a.diagnostics.looks_gamma_encoded) {
    for (size_t p = 0; p < r->status.size(); ++p)
      if (r->status[p] == kTexelOk) {
        r->status[p] = kTexelSuspectData;
        a.confidence.bound[p] = std::numeric_limits<float>::infinity();
      }
  }
  for (const auto& w : a.diagnostics.warnings) r->warnings.push_back(w);
  if (a.confidence.unverifiable > 0)
    r->warnings.push_back(std::to_string(a.confidence.unverifiable) +
                          " texel(s) cannot bound their error (fewer usable lights than the "
                          "model's light parameters + 3, no light within 45° of the normal, or lights that cannot predict other "
                          "directions): marked "
                          "'error cannot be bounded'");
  r->flagged_texels = 0;
  for (uint8_t s : r->status) r->flagged_texels += s != kTexelOk && s != kTexelMasked;
  return a;
}

}  // namespace matfit::fit
