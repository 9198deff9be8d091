// A PTM material with random coefficients (tests of the relighting bases): rendered through the
// shared forward model, its stacks lie exactly in the PTM basis's span. Deterministic.
#pragma once

#include "core/material_maps.h"
#include "core/synth/random.h"

namespace matfit::fit {

// Coefficients uniform in [−0.3, 0.7), 6 per channel.
inline MaterialMaps RandomPtm(int size) {
  MaterialMaps m;
  m.width = m.height = size;
  m.model = ShadingModel::kPtm;
  m.normal = Image(size, size, 3);
  m.albedo = Image(size, size, 3);
  m.mask = Image(size, size, 1, 1.0f);
  m.height_map = Image(size, size, 1);
  m.coefficients = Image(size, size, 18);
  m.basis_terms = 6;
  for (int q = 0; q < 18; ++q)
    for (int64_t p = 0; p < int64_t(size) * size; ++p)
      m.coefficients.Plane(q)[p] = float(synth::HashUniform(9, q, p) - 0.3);
  return m;
}

}  // namespace matfit::fit
