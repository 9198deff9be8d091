#include "fit/fit_job_streamed.h"

#include <optional>
#include <string>
#include <vector>

#include "core/dataset/info.h"
#include "fit/fit_job_finish.h"
#include "fit/holdout_views.h"
#include "fit/method.h"
#include "fit/per_view_fit.h"
#include "fit/stream_fit.h"
#include "fit/stream_per_view.h"

namespace matfit::fit::job {

StatusOr<FitJobResult> RunStreamedJob(const FitJobOptions& o, int64_t budget, StreamedFit* sf,
                                      Stages* stages) {
  const std::string size =
      Megabytes(sf->FloatBytes()) + " as float > --memory " + Megabytes(budget);
  const auto method = MakeMethod(o.model);
  const bool per_view = method && PerViewBase(*method);
  if (o.model != "svbrdf" && !per_view)
    return InvalidArgument("--model " + o.model + ": this stack (" + size +
                           ") is fitted out of core, which --model svbrdf and per-view:MODEL do; "
                           "name one, or raise --memory to fit in memory");
  if (sf->shape().has_light_positions())
    return InvalidArgument(o.model +
                           ": near lights (light_positions.txt) over several views are not "
                           "supported; use --distant-lights");
  if (o.holdout != 0 || !o.pca_components.empty())
    return InvalidArgument("--holdout/--components: this stack (" + size +
                           ") is fitted out of core, where held-out light folds and the PCA "
                           "reference are not run yet (--holdout-views is); raise --memory or "
                           "drop them");
  // Held-out views: each band is refined a second time without them (fit/stream_fit.h).
  std::vector<int> held;
  if (o.holdout_views > 0) {
    const auto groups = ViewGroups(sf->shape());
    const int v = int(groups.size());
    if (o.holdout_views > v - 1)
      return InvalidArgument("--holdout-views must be in [1, " + std::to_string(v - 1) +
                             "] for this stack of " + std::to_string(v) +
                             " views (the most frontal view is always fitted), got " +
                             std::to_string(o.holdout_views));
    held = ChooseHeldOutViews(sf->shape(), groups, o.holdout_views);
  }
  stages->End();  // read: the headers
  FitJobResult r;
  r.images = int(sf->shape().lights().size());
  r.width = sf->shape().width(), r.height = sf->shape().height();
  r.channels = sf->shape().channels();
  if (per_view) {  // one view at a time (fit/stream_per_view.h): no cache
    if (!stages->Begin("fit", int64_t(ViewGroups(sf->shape()).size() + held.size())))
      return Cancelled();
    auto pv =
        FitPerViewOutOfCore(o.input, o.read, sf->shape(), *method, o.fit, held, stages->Callback());
    if (!pv.ok()) return pv.status();
    stages->End();
    r.reconstruction = pv->reconstruction;
    r.reconstruction_common = pv->reconstruction_common;
    r.deviation_by_view_theta = pv->deviation_by_view_theta;
    r.heldout_views = pv->heldout_views;
    r.tone = pv->tone;
    r.assessment = std::move(pv->assessment);
    r.read_encoding = pv->read_encoding;
    pv->fit.parameters["streamed_views"] = double(ViewGroups(sf->shape()).size());
    const std::vector<uint8_t> fitted_status = pv->fit.views[size_t(pv->fit.frontal_view)].status;
    MATFIT_RETURN_IF_ERROR(FinishJob(o, sf->shape(), *method, std::nullopt, SceneSpec{},
                                     fitted_status, std::move(pv->fit), stages, &r));
    r.timings = stages->Snapshot();
    return r;
  }
  if (!stages->Begin("cache", r.images)) return Cancelled();
  StreamFitOptions so;
  so.memory_bytes = budget, so.cache_dir = o.cache_dir;
  so.holdout_views = !held.empty();
  MATFIT_RETURN_IF_ERROR(sf->BuildCache(so, stages->Callback()));
  stages->End();
  if (!stages->Begin("start")) return Cancelled();
  MATFIT_RETURN_IF_ERROR(sf->FitStart(o.fit));
  stages->End();
  if (!stages->Begin("fit", sf->bands())) return Cancelled();
  MATFIT_RETURN_IF_ERROR(sf->FitBands(o.fit, stages->Callback(), held));
  stages->End();
  r.reconstruction = sf->reconstruction();
  r.reconstruction_common = sf->reconstruction_common();
  r.tone = sf->tone();
  r.deviation_by_view_theta = sf->DeviationByViewTheta();
  r.heldout_views = sf->heldout_views();
  r.streamed_bands = sf->bands();
  r.read_encoding = DescribeReadEncoding(sf->decoded());
  FitResult fit = std::move(sf->result());
  fit.parameters["streamed_cache_mb"] = double(sf->cache_bytes()) / (1 << 20);
  const std::vector<uint8_t> fitted_status = fit.status;
  MATFIT_RETURN_IF_ERROR(FinishJob(o, sf->shape(), *method, std::nullopt, SceneSpec{},
                                   fitted_status, std::move(fit), stages, &r));
  r.timings = stages->Snapshot();
  return r;
}

}  // namespace matfit::fit::job
