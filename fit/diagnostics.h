// Stack-level checks that no per-texel residual can reveal. Gamma-encoded images read as
// linear (the classic gamma mistake) are fitted consistently by every model, yet every map is
// wrong; the encoding shows in how the values grow with n·l.
#pragma once

#include <string>
#include <vector>

#include "core/light_stack.h"

namespace matfit::fit {

struct StackDiagnostics {
  // γ̂ minimising the pooled relative residual of a per-texel Lambertian fit to p^γ (luminance,
  // the middle 65 % of each texel's samples, so highlights and shadows do not decide).
  double encoding_exponent = 1;
  double residual_linear = 0, residual_best = 0;  // relative residual at γ = 1 and at γ̂
  int texels_used = 0;
  bool looks_gamma_encoded = false;  // γ̂ ∈ [1.6, 3] and residual_best < residual_linear / 2
  std::vector<std::string> warnings;
};

// Samples at most max_texels texels on a regular grid (pure computation).
StackDiagnostics DiagnoseStack(const LightStack& stack, int max_texels = 2048);

}  // namespace matfit::fit
