// The fitting ladder behind one interface: fit(stack, options) → maps + per-texel status.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "core/light_stack.h"
#include "core/status.h"
#include "fit/fit_types.h"

namespace matfit::fit {

class FitMethod {
 public:
  virtual ~FitMethod() = default;
  virtual std::string name() const = 0;
  virtual std::string description() const = 0;
  virtual int parameters_per_texel() const = 0;  // fitted scalars per texel
  virtual int bytes_per_texel() const = 0;       // as stored in a pack
  // Parameters the variation over lights must determine at one texel (channels share the
  // geometry: lambert 3 = normal 2 + albedo level): a texel needs this many usable lights + 3
  // before its residual can bound its error (fit/confidence.h).
  virtual int light_parameters() const = 0;
  // Of parameters_per_texel (counted for RGB), those fitted once per colour channel (lambert: the
  // albedo, 1): a grey stack fits parameters_per_texel − 2 · this.
  virtual int parameters_per_channel() const = 0;
  virtual StatusOr<FitResult> Fit(const LightStack& stack, const FitOptions& options) const = 0;
};

std::vector<std::string> MethodNames();  // the ladder, simplest first
// Methods over the views of a multi-view stack (issue 17; `--view all`): fitted only when asked
// for by name, not part of the single-view ladder that bench, stability and auto run.
std::vector<std::string> MultiViewMethodNames();
// per-view:<model> for every model of the ladder (fit/per_view_fit.h): each view fitted on its
// own; also fitted only when asked for by name.
std::vector<std::string> PerViewMethodNames();
// nullptr when `name` is not a method.
std::unique_ptr<FitMethod> MakeMethod(const std::string& name);

}  // namespace matfit::fit
