// Sensor-like perturbations of a rendered stack, applied in the order a camera would:
// misregistration (geometry) → shot noise → Gaussian read noise → clipping. 8-bit sRGB
// quantisation happens when the dataset is written (--bits 8).
#pragma once

#include <cstdint>
#include <string>

#include "core/light_stack.h"

namespace matfit::synth {

struct PerturbOptions {
  double gaussian_sigma = 0;  // additive N(0, σ²) per sample, σ as a fraction of full scale, ≥ 0
  double shot_photons = 0;    // photons at full scale (Poisson ≈ N(p, p/K)); 0 = off, else ≥ 1
  double clip = 0;            // saturation level in (0, 1]: p = min(p, clip); 0 = off
  double misregister_px = 0;  // per-image random shift, uniform in [−s, s] px per axis; ≥ 0
  uint64_t seed = 1;

  bool Check(std::string* why) const;
  bool any() const {
    return gaussian_sigma > 0 || shot_photons > 0 || clip > 0 || misregister_px > 0;
  }
};

// Per-image shifts actually applied (x right, y down, pixels), for the record.
struct PerturbRecord {
  std::vector<double> shift_x, shift_y;
  int64_t clipped_samples = 0;
};

PerturbRecord ApplyPerturbations(const PerturbOptions& options, LightStack* stack);

}  // namespace matfit::synth
