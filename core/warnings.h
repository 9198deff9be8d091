// Every warning matfit gives has a code: "code: message" in the CLI summary, `matfit info`,
// report.json `warnings` and leaves.json. The table (code, where it comes from, what it means)
// is docs/cli.md's; a test keeps the two equal.
#pragma once

#include <span>
#include <string>

namespace matfit {

enum class WarningCode {
  // Dataset (matfit info, and every fit of it).
  kTooFewLights,
  kCoplanarLights,
  kIllConditionedLights,
  kLightsBelowHorizon,
  kDuplicateLights,
  kAzimuthGap,
  kElevationSpan,
  kClippedPixels,
  kNonfiniteSamples,
  kBlackImages,
  kEmptyMask,
  kAlphaDropped,
  kLpPathFallback,
  kGammaEncoded,
  kLinearReadAsSrgb,
  kEncodingAssumed,
  kToneCorrected,
  // Fit.
  kFlaggedTexels,
  kOverfitRisk,
  kUnboundedError,
  kNoSpecularLobe,
  kNoViewAlignedLight,
  kPackAtMip,
  kMipFootprint,
  kBudgetNotMet,
  kViewsOutsideScene,
  kTruthUnusable,
  // Leaf.
  kNoScale,
  kLeafFlagged,
  kLeafAtBorder,
  kLeafNoTopLight,
  kLeafSpecularFailed,
  kLeafNarrowLights,
  kThicknessEstimated,
  kSaturatedBacklight,
  kKernelRadiusCut,
  kThinTexels,
  kThicknessExpansion,
};

struct WarningSpec {
  WarningCode code;
  const char* name;     // "azimuth-gap"
  const char* source;   // "dataset", "fit" or "leaf"
  const char* meaning;  // one line for docs/cli.md
};

std::span<const WarningSpec> AllWarnings();
const char* WarningName(WarningCode code);
// "name: message".
std::string Warning(WarningCode code, const std::string& message);

}  // namespace matfit
