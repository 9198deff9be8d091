// Stack-wide figures of a stack that may be one row band of a distributed stack
// (LightStack::band): each helper reduces over the ranks when it is, and is the identity when the
// stack is whole. Every rank of the band's communicator must call them in the same order.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/comm.h"
#include "core/light_stack.h"
#include "core/status.h"

namespace matfit {

// The error for images whose alpha channel (`source`, e.g. "alpha channel (3 of 3 images)") is
// transparent at every pixel.
inline Status AlphaTransparentError(const std::string& source) {
  return DataError("the " + source +
                   " is transparent at every pixel, so no pixel would be fitted; save the images "
                   "without alpha, or make the sample opaque");
}

// Σ over the bands (rank order), element by element.
inline void SumOverBands(const LightStack& s, double* values, int n) {
  if (s.band.comm) SumAcross(*s.band.comm, values, n);
}
inline void SumOverBands(const LightStack& s, int64_t* values, int n) {
  if (s.band.comm) SumAcross(*s.band.comm, values, n);
}
// The bands' vectors one after another: for per-row or per-texel data, the whole stack's in row
// order.
template <typename T>
std::vector<T> ConcatOverBands(const LightStack& s, const std::vector<T>& mine) {
  return s.band.comm ? ConcatAcross(*s.band.comm, mine) : mine;
}

// Makes *s, read as rows [s->band.row0, + height()) of every image, one band of a stack
// distributed over `comm`: the per-image counts the reader made of its rows (saturated pixels,
// non-finite samples) become the whole stack's. A collective.
// A mask read from the images' alpha channel is judged as one process judges it
// (core/dataset/stack_loader.h): transparent everywhere is an error (the same on every rank),
// opaque everywhere is no mask.
inline Status JoinBands(LightStack* s, const Comm* comm) {
  s->band.comm = comm;
  if (s->band.full_height == 0) s->band.full_height = s->height();
  SumOverBands(*s, s->saturated_pixels.data(), int(s->saturated_pixels.size()));
  SumOverBands(*s, s->nonfinite_samples.data(), int(s->nonfinite_samples.size()));
  if (s->mask_source.rfind("alpha channel", 0) == 0) {
    int64_t counts[2] = {0, int64_t(s->mask.size())};
    for (uint8_t v : s->mask) counts[0] += v;
    SumOverBands(*s, counts, 2);
    if (counts[0] == 0) return AlphaTransparentError(s->mask_source);
    if (counts[0] == counts[1]) {
      s->mask.clear();
      s->mask_source = "none: the " + s->mask_source + " is opaque everywhere";
    }
  }
  return Status::Ok();
}

}  // namespace matfit
