// Synthetic datasets for the fit tests (in memory, float, lp layout: no angle quantisation).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "core/synth/synth.h"

namespace matfit::fit {

struct SynthSpec {
  std::string material = "plaster";
  std::string lights = "bonn81";
  int size = 32;
  double noise = 0;      // Gaussian σ, fraction of full scale
  bool shadows = false;  // cast shadows from the height field
};

inline synth::SynthResult SynthData(const SynthSpec& spec) {
  synth::SynthOptions o;
  o.material = spec.material;
  o.lights = spec.lights;
  o.size = spec.size;
  o.shadows = spec.shadows;
  o.layout = Layout::kLp;
  o.bits = 32;
  o.perturb.gaussian_sigma = spec.noise;
  auto r = synth::Synthesize(o);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  return r.ok() ? std::move(*r) : synth::SynthResult{};
}

// Largest absolute difference between two images of the same size (all planes).
inline double MaxAbsDiff(const Image& a, const Image& b) {
  double m = 0;
  for (size_t i = 0; i < a.data().size(); ++i)
    m = std::max(m, double(std::abs(a.data()[i] - b.data()[i])));
  return m;
}

}  // namespace matfit::fit
