// The steps of a fit job after scoring (truth, report.json, the pack) and the helpers the job
// shares with them. Internal to the job (fit/fit_job.cc).
#pragma once

#include <optional>
#include <vector>

#include "core/light_stack.h"
#include "core/status.h"
#include "fit/fit_job.h"
#include "fit/fit_job_stages.h"
#include "fit/method.h"
#include "fit/report.h"
#include "fit/select.h"

namespace matfit::fit::job {

// The truth maps of the stack's region: a dataset read with --crop is compared with the same
// region of its truth (maps of the whole images' size are cut; a stack at a lower mip, or truth
// of another size, is left to fail the size check).
StatusOr<MaterialMaps> TruthOfRegion(StatusOr<MaterialMaps> truth, const LightStack& stack);

// report.json's "crop": the region of the source images read with --crop (also when the pack
// is at a lower mip of it).
std::optional<FitReportInputs::Region> CropRegion(const LightStack& s);

// The steps after scoring, on the whole stack's maps (rank 0 of a distributed fit): truth,
// report.json and the pack.
Status FinishJob(const FitJobOptions& o, const LightStack& stack, const FitMethod& method,
                 const std::optional<Selection>& selection, const SceneSpec& scene,
                 const std::vector<uint8_t>& fitted_status, FitResult fit, Stages* stages,
                 FitJobResult* out);

}  // namespace matfit::fit::job
