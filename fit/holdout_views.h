// Held-out views (issue 17): whole views of a multi-view stack left out of the fit and predicted
// by it — what a renderer drawing the material from a new camera shows. And the reconstruction
// error of a multi-view fit per (θv, θl) group.
#pragma once

#include <functional>
#include <map>
#include <utility>
#include <vector>

#include "core/light_stack.h"
#include "fit/method.h"
#include "fit/metrics.h"

namespace matfit::fit {

struct HeldOutView {
  double theta_deg = 0, phi_deg = 0;  // the view
  ReconstructionMetrics metrics;      // its images predicted by the fit without it
};

struct HeldOutViewMetrics {
  std::vector<HeldOutView> views;  // the held-out views, by θv
  ReconstructionMetrics all;       // every held-out image
  int train_views = 0;
};

// `count` views spread over the view range in θv order (every (V − 1)/count-th of the views
// sorted by θv, φv), never the most frontal one (svbrdf starts from it): indices into `groups`
// (ViewGroups). count must be in [1, V − 1].
std::vector<int> ChooseHeldOutViews(const LightStack& stack,
                                    const std::vector<std::vector<int>>& groups, int count);

// The images of the views `held` (indices into `groups`) and of the others, each in stack order.
void SplitByViews(const std::vector<std::vector<int>>& groups, const std::vector<int>& held,
                  std::vector<int>* train, std::vector<int>* test);

// Fits `method` on the images of the other views and scores the held-out views' images with it
// (reconstruction metrics, each image at its own view). options.progress sees the fit.
StatusOr<HeldOutViewMetrics> HeldOutViews(const FitMethod& method, const LightStack& stack,
                                          int count, const FitOptions& options);

// dev% per (θv, θl) group of the maps' reconstruction of a multi-view stack: outer key θv, inner
// θl, each rounded to the nearest multiple of 15° (as ReconstructionMetrics's θl groups).
std::map<int, std::map<int, double>> DeviationByViewTheta(const LightStack& stack,
                                                          const MaterialMaps& maps,
                                                          const std::vector<uint8_t>& status);
// The same in parts (bands of a streamed fit): Σ dev%·samples and Σ samples per group, added up
// over the parts, then divided.
using ViewThetaSums = std::map<int, std::map<int, std::pair<double, double>>>;
void AddDeviationByViewTheta(const LightStack& stack, const MaterialMaps& maps,
                             const std::vector<uint8_t>& status, ViewThetaSums* sums);
std::map<int, std::map<int, double>> DeviationByViewTheta(const ViewThetaSums& sums);
// The same with maps that depend on the view (per-view fits): maps_of(view) gives the maps and
// status that predict that view's images.
using MapsOfView =
    std::function<std::pair<const MaterialMaps*, const std::vector<uint8_t>*>(const Vec3& view)>;
void AddDeviationByViewTheta(const LightStack& stack, const MapsOfView& maps_of,
                             ViewThetaSums* sums);

}  // namespace matfit::fit
