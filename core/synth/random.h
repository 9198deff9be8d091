// Counter-based randomness: every value is a pure function of (seed, indices), so synthetic
// data is identical for a given seed whatever the thread count or evaluation order.
#pragma once

#include <cstdint>

namespace matfit::synth {

// SplitMix64 finaliser over a combination of the inputs.
uint64_t Hash(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0);
// Uniform in [0, 1) with 53 random bits.
double HashUniform(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0);
// Standard normal (Box–Muller on two hashed uniforms).
double HashGaussian(uint64_t seed, uint64_t a, uint64_t b = 0, uint64_t c = 0);

// Smooth value noise in [0, 1], periodic with `period` lattice cells in u and v, at
// coordinates measured in lattice cells (quintic interpolation, C2).
double ValueNoise(uint64_t seed, double u, double v, int period);
// Fractal sum of `octaves` value-noise layers (frequency ×2, amplitude ×0.5), in [0, 1],
// periodic over the unit square: u, v in sample widths, base_freq cells per sample width.
double Fbm(uint64_t seed, double u, double v, int base_freq, int octaves);
// Cellular noise: distance to the nearest of one jittered feature point per cell (periodic
// over the unit square, `freq` cells per width) and that point's cell id.
struct CellSample {
  double distance;  // in cell units
  uint64_t cell_id;
};
CellSample Cellular(uint64_t seed, double u, double v, int freq);

}  // namespace matfit::synth
