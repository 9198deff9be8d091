// How well the three HL2 terms reproduce the multipole translucency for one light elevation:
// mean relative error |Σ h_i ℋ_i(ω) − L_t^D(ω)| / L_t^D(ω) over the leaf's texels, for four
// azimuths (one when overhead), L_t^D by the direct sum. Texels lit by under 5 % of their
// unshadowed response (deep self-shadow) carry no signal and are left out.
#pragma once

#include <array>
#include <cstdint>

#include "core/status.h"
#include "leaf/translucency.h"

namespace matfit::leaf {

struct Hl2ErrorStats {
  double mean = 0;
  int64_t texels = 0;                  // texel × direction pairs compared
  std::array<int64_t, 6> histogram{};  // errors < 1, 2, 5, 10, 20, ≥ 20 %
};

// elevation: radians above the tangent plane (π/2 = overhead).
StatusOr<Hl2ErrorStats> Hl2ReconstructionError(const TransportInput& in,
                                               const TranslucencyOptions& options,
                                               const TranslucencyResult& result, double elevation);
// Several elevations in one direct sum, on at most `max_texels` leaf texels (an even subsample;
// 0 = every leaf texel): the direct sum costs texels × kernel area, so reports on large leaves
// sample them.
StatusOr<std::vector<Hl2ErrorStats>> Hl2ReconstructionErrors(const TransportInput& in,
                                                             const TranslucencyOptions& options,
                                                             const TranslucencyResult& result,
                                                             const std::vector<double>& elevations,
                                                             int64_t max_texels);

}  // namespace matfit::leaf
