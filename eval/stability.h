// The stability matrix: every method × every perturbation where methods fail (noise, shadows,
// highlights, clipping, the gamma mistake, misregistration, few / coplanar / grazing lights,
// NaN pixels, thin leaves), scored against ground truth. A method may fail; it must not fail
// silently: an ok texel whose relighting error exceeds its own bound (fit/confidence.h) is a
// silent failure. A refused dataset or a flagged texel is a failure the method knew about.
#pragma once

#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/progress.h"
#include "core/status.h"

namespace matfit::eval {

struct StabilityOptions {
  int size = 32;                     // texels per side of the synthetic cases, [8, 256]
  std::vector<std::string> methods;  // empty: the whole ladder (+ "leaf-hl2" for thin leaves)
  std::vector<std::string> cases;    // empty: every perturbation
  ProgressFn progress;

  bool Check(std::string* why) const;
};

struct StabilityCase {
  std::string name, description;
  bool degenerate = false;  // the data cannot support a full fit (few/coplanar/grazing lights,
                            // NaN, gamma, clipping): the silent-failure target is 0 here
};
const std::vector<StabilityCase>& StabilityCases();

struct StabilityCell {
  std::string method, perturbation;
  bool applicable = true;  // leaf-hl2 only runs on leaf cases, fits not on thin-leaf
  bool refused = false;    // the method returned an error (it knew)
  std::string error;       // its message
  int64_t texels = 0;      // texels scored (inside the truth mask)
  double error_median = NAN, error_p95 = NAN;  // relighting RMS error over a dome, linear
  double normal_mae_deg = NAN;                 // ok texels, methods with a normal
  double flagged_fraction = 0;                 // texels not ok (any reason)
  int warnings = 0;
  int64_t silent = 0;          // ok texels with error > bound
  double silent_fraction = 0;  // silent / texels
  double bound_median = NAN;
  // Tightness: bound / error per ok texel with an error > 0 (fit/confidence.h BoundRatio).
  double bound_ratio_median = NAN, bound_ratio_p90 = NAN;
};

struct StabilityResult {
  std::vector<std::string> methods, perturbations;
  std::vector<StabilityCell> cells;  // methods × perturbations, row-major
  int size = 0;
  double seconds = 0;
};

StatusOr<StabilityResult> RunStability(const StabilityOptions& options);

// stability.json (schema "matfit.stability/1").
std::string StabilityJson(const StabilityResult& result);

}  // namespace matfit::eval
