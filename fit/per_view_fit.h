// per-view:<model> (issue 17): any single-view model of the ladder fitted to each view of a
// multi-view stack on its own — the literature's baseline for BTFs (Daubert 2001, McAllister 2002
// fit per view) — and the scoring of fits whose maps differ per view: an image is predicted by
// the maps of its own view, or, for a view that was not fitted (held out), by those of the
// nearest fitted view (the nearest-view lookup a per-view BTF renderer does).
#pragma once

#include <map>
#include <memory>
#include <string>
#include <vector>

#include "core/light_stack.h"
#include "fit/fit_types.h"
#include "fit/method.h"
#include "fit/score.h"

namespace matfit::fit {

inline constexpr char kPerViewPrefix[] = "per-view:";

// The per-view method over `base` (a method of MethodNames(), e.g. "heinrich"); nullptr when
// base is not one (svbrdf and per-view methods are not bases). Its Fit takes a stack of one or
// more views; FitResult::views holds every view's fit, maps/status the most frontal view's.
// parameters_per_texel and bytes_per_texel are the base's per view (a pack of V views stores V
// times the bytes).
std::unique_ptr<FitMethod> MakePerViewMethod(const std::string& base);
// The base method of a per-view method (nullptr for any other method).
const FitMethod* PerViewBase(const FitMethod& method);

// The fitted view whose direction is nearest `view` (largest cosine; the first on ties). The
// fit must hold views.
int NearestViewFit(const FitResult& fit, const Vec3& view);

// ScoreStack (fit/score.h) over images `images` for any fit: one with views scores each image
// with the maps and status of its nearest fitted view (its own when fitted); `common` scores over
// CommonTexelStatus of the status. Reconstruction figures are summed exactly per (view, θl group);
// residuals per texel add up over the views (level weighted by samples). `progress` counts the
// parts scored.
StackScore ScoreFit(const LightStack& stack, const std::vector<int>& images, const FitResult& fit,
                    bool common, const ProgressFn& progress = {}, ScoreParts parts = {});
// The same over every image.
StackScore ScoreFit(const LightStack& stack, const FitResult& fit, bool common,
                    const ProgressFn& progress = {}, ScoreParts parts = {});

// dev% per (θv, θl) group (fit/holdout_views.h) of a per-view fit: each view with its maps.
std::map<int, std::map<int, double>> DeviationByViewTheta(const LightStack& stack,
                                                          const FitResult& fit);

}  // namespace matfit::fit
