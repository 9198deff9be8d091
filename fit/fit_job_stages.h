// The stages of a fit job (fit/fit_job.cc and the files it is split into): timing, progress,
// cancellation. Internal to the job.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>

#include "core/progress_fn.h"
#include "core/status.h"
#include "fit/fit_job.h"

namespace matfit::fit::job {

using Clock = std::chrono::steady_clock;

inline double Since(Clock::time_point t) {
  return std::chrono::duration<double>(Clock::now() - t).count();
}

// The stages of one job: announces each to the progress callback (done = 0 at the start, done =
// total at the end unless the stage's own callback got there) and times it.
class Stages {
 public:
  explicit Stages(const StageProgress& progress) : progress_(progress), start_(Clock::now()) {}

  // Starts `name` (ending nothing: stages do not overlap); false = cancelled.
  bool Begin(const char* name, int64_t total = 1) {
    name_ = name, total_ = total, reached_ = false, begin_ = Clock::now();
    return !progress_ || progress_(name_, 0, total_);
  }
  // The stage's own callback for the code it runs (empty without a progress callback).
  ProgressFn Callback() {
    if (!progress_) return {};
    return [this, name = name_](int64_t d, int64_t t) {
      if (t > 0) total_ = t;  // End() completes the stage in the callback's own units
      if (t > 0 && d >= t) reached_ = true;
      return progress_(name, d, t);
    };
  }
  // Ends the running stage: records its time, reports it complete.
  void End() {
    timings_.stages.emplace_back(name_, Since(begin_));
    if (progress_ && !reached_) progress_(name_, total_.load(), total_.load());
  }
  // Completed stages, and the running one so far when `running` is set; total so far.
  StageTimings Snapshot(bool running = false) const {
    StageTimings t = timings_;
    if (running) t.stages.emplace_back(name_, Since(begin_));
    t.total = Since(start_);
    return t;
  }

 private:
  const StageProgress& progress_;
  Clock::time_point start_, begin_;
  std::string name_;
  std::atomic<int64_t> total_{1};
  std::atomic<bool> reached_{false};
  StageTimings timings_;
};

inline Status Cancelled() { return Status(StatusCode::kCancelled, "cancelled"); }

inline std::string Megabytes(int64_t bytes) {
  return std::to_string((bytes + (1 << 19)) >> 20) + " MB";
}

}  // namespace matfit::fit::job
