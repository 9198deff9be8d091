// The shared fit of the relighting bases (ptm, hsh, rbf; fit/linear_basis_fit.cc): a basis of
// K functions of the light direction, the same for every texel, so one pseudo-inverse B⁺ serves
// all texels (coefficients = B⁺ · p per channel); texels with a clipped or lost sample are fitted
// again from their valid lights alone (fit/valid_refit.h).
#pragma once

#include <functional>
#include <string>
#include <string_view>

#include "core/light_stack.h"
#include "core/status.h"
#include "fit/fit_types.h"

namespace matfit::fit {

// basis(l, out): the K basis values B_j(l) of a unit light direction.
using BasisFn = std::function<void(const Vec3&, double*)>;

// `name` is the method (report and errors), `model` the ShadingModel name of the maps.
// srgb: fit the sRGB encode of each sample (divided by its light's intensity, clamped to
// [0, 1]) — the stored 8-bit code for an sRGB file under unit intensity — as RTI tools do; the
// maps then say basis_srgb and every evaluator decodes the sum.
StatusOr<FitResult> FitLinearBasis(const LightStack& s, const FitOptions& o,
                                   const std::string& name, std::string_view model, int K,
                                   const BasisFn& basis, bool srgb);

}  // namespace matfit::fit
