// Stack-wide figures of a stack that may be one row band of a distributed stack
// (LightStack::band): each helper reduces over the ranks when it is, and is the identity when the
// stack is whole. Every rank of the band's communicator must call them in the same order.
#pragma once

#include <cstdint>
#include <vector>

#include "core/comm.h"
#include "core/light_stack.h"

namespace matfit {

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
inline void JoinBands(LightStack* s, const Comm* comm) {
  s->band.comm = comm;
  if (s->band.full_height == 0) s->band.full_height = s->height();
  SumOverBands(*s, s->saturated_pixels.data(), int(s->saturated_pixels.size()));
  SumOverBands(*s, s->nonfinite_samples.data(), int(s->nonfinite_samples.size()));
}

}  // namespace matfit
