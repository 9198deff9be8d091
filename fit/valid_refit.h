// Every texel gets the best estimate its samples support (issue 19): the one-matrix linear fits
// use all N samples of a texel, so a texel with a clipped sample (at the file's maximum code) or
// a non-finite one (dead pixel, decode hole) is flagged by them. RefitFromValidSamples fits such
// texels again, one by one, from the samples that remain when those are dropped; a texel stays
// flagged only when the rest cannot determine the model (too few or coplanar lights).
#pragma once

#include <cstdint>
#include <functional>

#include "fit/fit_types.h"

namespace matfit {
class LightStack;
}

namespace matfit::fit {

// One texel's samples for a refit. obs[i · C + c] = p_ic / I_ic; valid[i] = 1 when every
// channel of light i is finite and (in a stack that may be clipped) below the clip level; obs of
// an invalid light is 0.
struct TexelSamples {
  int64_t p = 0;  // plane index
  int n = 0, channels = 0;
  const double* obs = nullptr;
  const uint8_t* valid = nullptr;
  int valid_count = 0;
};

// A model's fit of one texel from its valid samples: writes that texel's maps into *r and
// returns its status (kTexelOk, or why the valid samples do not determine the model).
using SubsetFit = std::function<uint8_t(const TexelSamples&, FitResult* r)>;

// Which sample kinds a model drops: mean keeps clipped samples (a clipped code still bounds the
// mean from below), every other model drops both.
struct RefitOptions {
  bool drop_clipped = true;
};

// Refits every texel whose status is kTexelSaturated or kTexelNonFinite with `fit`, and records
// how many lights each refitted texel lost in r->dropped_lights (allocated when any texel is
// refitted) and the totals in r->refit_texels / r->dropped_samples. Rows without such texels
// are not read. Runs over rows with ParallelFor; no I/O.
void RefitFromValidSamples(const LightStack& s, const RefitOptions& options, const SubsetFit& fit,
                           FitResult* r);

}  // namespace matfit::fit
