// Progress of long jobs. Compute code only calls a ProgressFn; the terminal reporter below
// turns calls into a bar with ETA on a TTY, or plain periodic lines otherwise (logs, CI).
#pragma once

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <functional>
#include <mutex>
#include <string>

#include "core/progress_fn.h"

namespace matfit {

class ProgressReporter {
 public:
  enum class Style { kAuto, kBar, kLines, kQuiet };
  // Style kAuto picks kBar when `out` is a terminal, kLines otherwise.
  ProgressReporter(std::string label, FILE* out = stderr, Style style = Style::kAuto);
  ~ProgressReporter();  // finishes the line if the job did not reach total

  // Thread-safe; throttled to about 10 redraws/s (bar) or a line per 10 % / 5 s (lines).
  void Update(int64_t done, int64_t total);
  void Finish();
  ProgressFn Callback();  // adapter that forwards to Update and never cancels

  // Formatting helpers, public for tests: "[#####-----]  50% 5/10 ETA 3s".
  static std::string FormatBar(int64_t done, int64_t total, double elapsed_s, int width);
  static std::string FormatDuration(double seconds);  // "42s", "3m05s", "1h02m"

 private:
  std::string label_;
  FILE* out_;
  Style style_;
  std::mutex mutex_;
  std::chrono::steady_clock::time_point start_, last_draw_;
  int64_t last_done_ = -1, total_ = 0;
  int last_decile_ = -1;
  bool finished_ = false, drew_ = false;
};

}  // namespace matfit
