// Stack-level checks that no per-texel residual can reveal. Gamma-encoded images read as
// linear (the classic gamma mistake), or linear ones decoded as sRGB, are fitted consistently by
// every model, yet every map is wrong; the encoding shows in how the values grow with n·l
// (radiometric self-calibration from photometric consistency, as in Shi et al., "Self-calibrating
// photometric stereo", CVPR 2010, here with a one-parameter curve family; docs/stability.md).
#pragma once

#include <string>
#include <vector>

#include "core/light_stack.h"

namespace matfit::fit {

// What the stack says about its own tone curve, relative to how it was read.
enum class ToneVerdict {
  kUnknown,           // too few usable texels, or the search ended at its range
  kAsRead,            // values grow like n·l: the read linearised them
  kSrgbReadAsLinear,  // sRGB-encoded files read as linear (an sRGB decode fits as well as γ̂)
  kLinearReadAsSrgb,  // linear files decoded as sRGB (an sRGB encode fits as well as γ̂)
  kPower,             // a power curve: v^γ̂ is linear in n·l, neither sRGB form fits as well
};
const char* ToneVerdictName(ToneVerdict v);

struct StackDiagnostics {
  // Radiometric self-calibration: γ̂ minimising the pooled relative residual of a per-texel
  // Lambertian fit to p^γ over the darker middle ranks of each texel's luminance (highlights and
  // cast shadows do not decide), γ ∈ [0.3, 3.3]; the read values v then satisfy v^γ̂ ∝ radiance.
  double encoding_exponent = 1;
  double residual_linear = 0, residual_best = 0;  // relative residual at γ = 1 and at γ̂
  // The same residual with an sRGB decode / encode applied to each channel's value.
  double residual_srgb_decoded = 0, residual_srgb_encoded = 0;
  // residual_linear / residual_best: how much better γ̂ explains the data than the read (1 = no
  // better; ≥ 2 is strong evidence, < 1.25 none).
  double evidence = 1;
  ToneVerdict verdict = ToneVerdict::kUnknown;
  int texels_used = 0;
  bool looks_gamma_encoded = false;  // γ̂ ∈ [1.6, 3] and residual_best < residual_linear / 2
  bool looks_linear_read_as_srgb = false;  // verdict kLinearReadAsSrgb with evidence ≥ 1.25
  std::vector<std::string> warnings;
};

// One line for `matfit info` and the fit summary: "γ̂ 0.43 (evidence 1.6): linear files ...".
std::string DescribeToneCurve(const StackDiagnostics& d);

// Samples at most max_texels texels on a regular grid (pure computation).
StackDiagnostics DiagnoseStack(const LightStack& stack, int max_texels = 2048);

// --color-space auto acting on the estimate. When an integer stack's codes were linearised by a
// rule rather than by the user (file metadata, the bit-depth convention, a layout default) and
// the stack shows a mistake that rule can make — sRGB or a power curve read as linear, linear
// decoded as sRGB — with evidence ≥ kToneActEvidence, over lit lights spanning at least
// kMinToneElevationSpanDeg of elevation (one ring bends values like a curve: a glossy Blinn–Phong
// ring read as linear gives γ̂ 0.38, evidence 1.29), the code table is rebuilt with the curve the
// stack shows, when that curve's Lambertian residual on the diagnosed samples is at least
// kToneSwitchGain times smaller than the read's (a standard curve can explain less than the
// fitted γ̂: psm gray, γ̂ gain 1.55, linear gain 1.3). The re-read stack is diagnosed again; if it
// shows a mistake of its own the change is undone. No file is re-read and no sample rewritten
// (LightStack::Relinearise).
inline constexpr double kToneActEvidence = 1.4, kToneSwitchGain = 1.2;
inline constexpr double kMinToneElevationSpanDeg = 5;
struct ToneResolution {
  bool corrected = false;
  ColorEncoding from, to;
  std::string from_reason;
  StackDiagnostics before;  // the diagnosis of the stack as first read
};
// Call only for --color-space auto. *diag: in, the diagnosis of *stack as read (DiagnoseStack);
// out, that of the stack as it now stands, with a tone-corrected warning when corrected.
ToneResolution ResolveToneCurve(LightStack* stack, StackDiagnostics* diag);

}  // namespace matfit::fit
