#include "core/synth/light_sets.h"

#include <cmath>
#include <numbers>

#include "core/synth/random.h"
#include "core/text_file.h"

namespace matfit::synth {
namespace {

LightSample FromAngles(double theta, double phi) {
  LightSample s;
  s.direction = DirectionFromAnglesDeg(theta, phi);
  s.theta_deg = theta;
  s.phi_deg = phi;
  return s;
}

Status BadSpec(const std::string& spec) {
  return InvalidArgument("--lights '" + spec +
                         "' is not a light set; use bonn81, ring12, "
                         "ring:N[:THETA], dome:N or random:N (N ≥ 1, THETA in (0, 90))");
}

}  // namespace

StatusOr<std::vector<LightSample>> MakeLightSet(const std::string& spec, uint64_t seed) {
  std::vector<LightSample> lights;
  if (spec == "bonn81") {
    const int thetas[] = {0, 15, 30, 45, 60, 75}, counts[] = {1, 6, 12, 18, 20, 24};
    for (int r = 0; r < 6; ++r)
      for (int k = 0; k < counts[r]; ++k)
        lights.push_back(FromAngles(thetas[r], 360.0 * k / counts[r]));
    return lights;
  }
  if (spec == "ring12") return MakeLightSet("ring:12:45", seed);
  const auto colon = spec.find(':');
  if (colon == std::string::npos) return BadSpec(spec);
  const std::string kind = spec.substr(0, colon);
  std::string rest = spec.substr(colon + 1), second;
  if (const auto c2 = rest.find(':'); c2 != std::string::npos) {
    second = rest.substr(c2 + 1);
    rest = rest.substr(0, c2);
  }
  int n = 0;
  if (!ParseInt(rest, &n) || n < 1 || n > 100000) return BadSpec(spec);
  if (kind == "ring") {
    double theta = 45;
    if (!second.empty() && (!ParseFiniteDouble(second, &theta) || theta <= 0 || theta >= 90))
      return BadSpec(spec);
    for (int k = 0; k < n; ++k) lights.push_back(FromAngles(theta, 360.0 * k / n));
    return lights;
  }
  if (!second.empty()) return BadSpec(spec);
  if (kind == "dome") {
    // Fibonacci spiral, equal-area in cos θ over [cos 75°, 1].
    const double zmin = std::cos(75.0 * std::numbers::pi / 180.0);
    const double golden = std::numbers::pi * (3.0 - std::sqrt(5.0));
    for (int k = 0; k < n; ++k) {
      const double z = 1.0 - (1.0 - zmin) * (k + 0.5) / n;
      const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
      lights.push_back(LightFromDirection({r * std::cos(golden * k), r * std::sin(golden * k), z}));
    }
    return lights;
  }
  if (kind == "random") {
    const double zmin = std::cos(80.0 * std::numbers::pi / 180.0);
    for (int k = 0; k < n; ++k) {
      const double z = zmin + (1.0 - zmin) * HashUniform(seed, 0x11ab, k, 1);
      const double phi = 2.0 * std::numbers::pi * HashUniform(seed, 0x11ab, k, 2);
      const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
      lights.push_back(LightFromDirection({r * std::cos(phi), r * std::sin(phi), z}));
    }
    return lights;
  }
  return BadSpec(spec);
}

void QuantizeToIntegerDegrees(std::vector<LightSample>* lights) {
  for (LightSample& s : *lights) {
    double t = std::round(s.theta_deg), p = std::round(s.phi_deg);
    if (p >= 360) p -= 360;
    if (t == 0) p = 0;
    s.theta_deg = t;
    s.phi_deg = p;
    s.direction = DirectionFromAnglesDeg(t, p);
  }
}

}  // namespace matfit::synth
