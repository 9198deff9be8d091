// Light sets for synthetic data and simulated rigs.
//   bonn81          METHODS.md §1: θ 0°(1) 15°(6) 30°(12) 45°(18) 60°(20) 75°(24), φ from 0°
//   ring12          12 lights at θ = 45°, φ = 0°, 30°, ..., 330°
//   ring:N[:THETA]  N lights on a ring at θ = THETA degrees (default 45)
//   dome:N          N lights spread evenly over the hemisphere θ ≤ 75° (Fibonacci spiral)
//   random:N        N lights uniform in solid angle over θ ≤ 80°, from the seed
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/status.h"

namespace matfit::synth {

StatusOr<std::vector<LightSample>> MakeLightSet(const std::string& spec, uint64_t seed);

// Rounds each light to integer degrees (θ, φ): the Bonn layout stores angles that way.
void QuantizeToIntegerDegrees(std::vector<LightSample>* lights);

}  // namespace matfit::synth
