#include "core/warnings.h"

#include <array>

namespace matfit {
namespace {

using W = WarningCode;

constexpr std::array kWarnings = {
    WarningSpec{W::kTooFewLights, "too-few-lights", "dataset",
                "fewer than 3 lights: normals cannot be recovered"},
    WarningSpec{W::kCoplanarLights, "coplanar-lights", "dataset",
                "the light directions span a plane (rank < 3): normals cannot be recovered"},
    WarningSpec{W::kIllConditionedLights, "ill-conditioned-lights", "dataset",
                "light matrix condition number > 30: fitted normals amplify noise"},
    WarningSpec{W::kLightsBelowHorizon, "lights-below-horizon", "dataset",
                "lights at or below the surface plane (θ ≥ 90°)"},
    WarningSpec{W::kDuplicateLights, "duplicate-lights", "dataset",
                "two lights share a direction (within 0.05°)"},
    WarningSpec{W::kAzimuthGap, "azimuth-gap", "dataset",
                "the lights leave an azimuth gap wider than 120°: surfaces facing it are "
                "extrapolated"},
    WarningSpec{W::kElevationSpan, "elevation-span", "dataset",
                "every light lies within 5° of one elevation: models that separate θ "
                "(ptm, hsh, lobes) are poorly determined"},
    WarningSpec{W::kClippedPixels, "clipped-pixels", "dataset",
                "more than 0.1 % of pixels sit at the maximum code"},
    WarningSpec{W::kNonfiniteSamples, "nonfinite-samples", "dataset",
                "NaN or Inf samples in float images"},
    WarningSpec{W::kBlackImages, "black-images", "dataset", "images whose maximum is < 1e-4"},
    WarningSpec{W::kEmptyMask, "empty-mask", "dataset", "the mask selects no texel"},
    WarningSpec{W::kAlphaDropped, "alpha-dropped", "dataset",
                "the images have an alpha channel but a mask file is given: the mask file is "
                "used, the alpha is not"},
    WarningSpec{W::kLpPathFallback, "lp-path-fallback", "dataset",
                "`.lp` entries name absolute or another machine's paths (e.g. C:\\...): the "
                "files of those names beside the .lp file are read"},
    WarningSpec{W::kEncodingAssumed, "encoding-assumed", "dataset",
                "images carry no colour metadata: their encoding is the bit-depth convention "
                "(8-bit sRGB, deeper linear), not known"},
    WarningSpec{W::kToneCorrected, "tone-corrected", "dataset",
                "--color-space auto re-linearised the images with the tone curve the stack "
                "itself shows, not the one their metadata or bit depth suggested"},
    WarningSpec{W::kGammaEncoded, "gamma-encoded", "dataset",
                "values grow like (n·l)^(1/γ): gamma-encoded images read as linear"},
    WarningSpec{W::kLinearReadAsSrgb, "linear-read-as-srgb", "dataset",
                "values become linear in n·l only after an sRGB encode: linear images decoded "
                "as sRGB"},
    WarningSpec{W::kFlaggedTexels, "flagged-texels", "fit",
                "texels the fit could not trust (status map); above 5 % the summary says so"},
    WarningSpec{W::kOverfitRisk, "overfit-risk", "fit",
                "fewer than 2 lights per light-dependent coefficient, or a relighting basis the "
                "lights barely determine (condition number > 1000); auto skips the model"},
    WarningSpec{W::kUnboundedError, "unbounded-error", "fit",
                "texels whose error cannot be bounded from the lights"},
    WarningSpec{W::kNoSpecularLobe, "no-specular-lobe", "fit",
                "no texel shows a specular lobe; the per-texel diffuse fit is kept"},
    WarningSpec{W::kNoViewAlignedLight, "no-view-aligned-light", "fit",
                "heinrich: no light along the view direction, no seed specular map"},
    WarningSpec{W::kPackAtMip, "pack-at-mip", "fit",
                "--model auto chose a lower resolution than the dataset's"},
    WarningSpec{W::kMipFootprint, "mip-footprint", "fit",
                "the scene's footprint asks for a mip level the dataset does not reach"},
    WarningSpec{W::kBudgetNotMet, "budget-not-met", "fit",
                "no candidate met the error budget; the most accurate is used"},
    WarningSpec{W::kViewsOutsideScene, "views-outside-scene", "fit",
                "--model auto fitted only the BTF views the scene shows (view_theta_max_deg)"},
    WarningSpec{W::kTruthUnusable, "truth-unusable", "fit",
                "the dataset's truth/ folder could not be compared"},
    WarningSpec{W::kNoScale, "no-scale", "leaf",
                "no physical scale (markers or mm_per_pixel); a default is assumed"},
    WarningSpec{W::kLeafFlagged, "leaf-flagged", "leaf",
                "a leaf has more than 20 % of its texels flagged"},
    WarningSpec{W::kLeafAtBorder, "leaf-at-border", "leaf",
                "a leaf touches the image border and is probably cut off"},
    WarningSpec{W::kLeafNoTopLight, "leaf-no-top-light", "leaf",
                "no top-lit images: the upper normal is flat"},
    WarningSpec{W::kLeafSpecularFailed, "leaf-specular-failed", "leaf",
                "the leaf's Cook-Torrance fit failed; diffuse only"},
    WarningSpec{W::kLeafNarrowLights, "leaf-narrow-lights", "leaf",
                "the top-lit lights span too few elevations for the specular lobe"},
    WarningSpec{W::kThicknessEstimated, "thickness-estimated", "leaf",
                "thickness from Beer-Lambert transmission, scaled to a maximum"},
    WarningSpec{W::kSaturatedBacklight, "saturated-backlight", "leaf",
                "back-lit samples at the maximum code"},
    WarningSpec{W::kKernelRadiusCut, "kernel-radius-cut", "leaf",
                "the translucency kernel radius was cut to fit the leaf"},
    WarningSpec{W::kThinTexels, "thin-texels", "leaf",
                "texels thinner than the kernel model's range"},
    WarningSpec{W::kThicknessExpansion, "thickness-expansion", "leaf",
                "the kernel's thickness expansion reached its order limit"},
};

}  // namespace

std::span<const WarningSpec> AllWarnings() { return kWarnings; }

const char* WarningName(WarningCode code) {
  for (const auto& w : kWarnings)
    if (w.code == code) return w.name;
  return "warning";
}

std::string Warning(WarningCode code, const std::string& message) {
  return std::string(WarningName(code)) + ": " + message;
}

}  // namespace matfit
