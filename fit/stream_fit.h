// Out-of-core fits (issue 17): a multi-view stack larger than the memory budget is decoded once
// into a band-major cache on disk (core/dataset/band_cache.h) and fitted band by band. svbrdf is
// per texel once its start is known (cook-torrance on the most frontal view, read on its own), so
// each band's texels come out as an in-memory fit's. The fit job (fit/fit_job.h) drives the
// stages: Open, BuildCache ("cache"), FitStart ("start"), FitBands ("fit", scoring each band).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <string>

#include "core/dataset/band_cache.h"
#include "core/dataset/dataset.h"
#include "fit/diagnostics.h"
#include "fit/fit_types.h"
#include "fit/holdout_views.h"
#include "fit/metrics.h"

namespace matfit::fit {

// The default --memory budget of a multi-view fit (single-view fits are always in memory).
inline constexpr int64_t kDefaultMemoryBudget = int64_t(2) << 30;

struct StreamFitOptions {
  int64_t memory_bytes = kDefaultMemoryBudget;  // peak RSS the fit aims under
  std::string cache_dir;                        // empty: the system temp folder
  // Held-out views will be fitted too (FitBands): a band's training images are copied beside it,
  // so bands are sized to a third of what the budget leaves instead of a half.
  bool holdout_views = false;
};

class StreamedFit {
 public:
  // The dataset's images and lights without decoding a pixel (read: every view).
  static StatusOr<StreamedFit> Open(const std::string& input, const ReadOptions& read);
  const LightStack& shape() const { return shape_; }
  // The stack held as float32 (the largest an in-memory fit holds of it): images × texels ×
  // channels × 4 bytes. Streamed when above the budget.
  int64_t FloatBytes() const;
  // Decodes every image once into the band cache, bands sized to half of what the budget leaves
  // after the process's resident memory, the fit's per-thread buffers and the maps.
  Status BuildCache(const StreamFitOptions& options, const ProgressFn& progress);
  // Reads the most frontal view alone (with the cache's mask over every view) and fits svbrdf's
  // start on it. With --color-space auto the tone curve is estimated on it, as an in-memory fit
  // of the multi-view stack does (fit/diagnostics.h), and a correction applies to every band.
  Status FitStart(const FitOptions& options);
  // Loads, refines and scores each band; progress counts bands. The whole stack's maps, status
  // and figures after the last. With held_views (indices into ViewGroups(shape()), as
  // ChooseHeldOutViews gives them), each band is also refined over the other views' images and
  // scores the held-out ones: heldout_views() after the last band, equal to an in-memory
  // HeldOutViews (the same start, the same per-texel refinement).
  Status FitBands(const FitOptions& options, const ProgressFn& progress,
                  const std::vector<int>& held_views = {});
  const std::optional<HeldOutViewMetrics>& heldout_views() const { return heldout_views_; }

  FitResult& result() { return result_; }
  const ReconstructionMetrics& reconstruction() const { return reconstruction_; }
  // Over the common texel set (fit/metrics.h): every unmasked texel as stored.
  const ReconstructionMetrics& reconstruction_common() const { return reconstruction_common_; }
  const std::optional<ToneResolution>& tone() const { return tone_; }
  std::map<int, std::map<int, double>> DeviationByViewTheta() const;
  int bands() const { return cache_ ? cache_->bands() : 0; }
  int64_t cache_bytes() const { return cache_ ? cache_->bytes() : 0; }
  int64_t band_bytes() const { return band_bytes_; }
  // The images' lights and decode records (encodings, clipped pixels) once the cache is built.
  const LightStack& decoded() const { return cache_ ? cache_->meta() : shape_; }

 private:
  std::string input_;
  ReadOptions read_;
  LightStack shape_;
  std::unique_ptr<BandCache> cache_;
  int64_t band_bytes_ = 0;
  std::optional<FitResult> start_;
  FitResult result_;
  ReconstructionMetrics reconstruction_, reconstruction_common_;
  ViewThetaSums view_theta_;
  std::optional<HeldOutViewMetrics> heldout_views_;
  std::optional<ToneResolution> tone_;  // --color-space auto: the estimate on the frontal view
  std::string tone_reason_;
};

}  // namespace matfit::fit
