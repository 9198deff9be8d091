// A multi-view stack over the memory budget, fitted out of core (part of fit/fit_job.cc).
#pragma once

#include <cstdint>

#include "core/status.h"
#include "fit/fit_job.h"
#include "fit/fit_job_stages.h"

namespace matfit::fit {
class StreamedFit;
}

namespace matfit::fit::job {

// The band cache, svbrdf's start on the frontal view, the bands (or per-view:MODEL one view at
// a time), then truth and the pack as any fit (no confidence bound: it pools residual statistics
// over the whole stack). Ends the running "read" stage.
StatusOr<FitJobResult> RunStreamedJob(const FitJobOptions& o, int64_t budget, StreamedFit* sf,
                                      Stages* stages);

}  // namespace matfit::fit::job
