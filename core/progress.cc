#include "core/progress.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>

namespace matfit {

ProgressReporter::ProgressReporter(std::string label, FILE* out, Style style)
    : label_(std::move(label)), out_(out), style_(style) {
  if (style_ == Style::kAuto)
    style_ = (out_ && ::isatty(::fileno(out_))) ? Style::kBar : Style::kLines;
  start_ = last_draw_ = std::chrono::steady_clock::now();
}

ProgressReporter::~ProgressReporter() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (style_ == Style::kBar && drew_ && !finished_) std::fputc('\n', out_);
}

std::string ProgressReporter::FormatDuration(double s) {
  char buf[32];
  if (!std::isfinite(s) || s < 0) return "?";
  const long t = std::lround(s);
  if (t < 60)
    std::snprintf(buf, sizeof buf, "%lds", t);
  else if (t < 3600)
    std::snprintf(buf, sizeof buf, "%ldm%02lds", t / 60, t % 60);
  else
    std::snprintf(buf, sizeof buf, "%ldh%02ldm", t / 3600, (t % 3600) / 60);
  return buf;
}

std::string ProgressReporter::FormatBar(int64_t done, int64_t total, double elapsed, int width) {
  const double frac = total > 0 ? std::clamp(double(done) / double(total), 0.0, 1.0) : 0.0;
  const int fill = int(std::lround(frac * width));
  std::string bar = "[" + std::string(fill, '#') + std::string(width - fill, '-') + "]";
  char buf[96];
  std::snprintf(buf, sizeof buf, " %3d%% %lld/%lld", int(std::floor(frac * 100.0)), (long long)done,
                (long long)total);
  bar += buf;
  if (done >= total && total > 0)
    bar += " in " + FormatDuration(elapsed);
  else if (done > 0)
    bar += " ETA " + FormatDuration(elapsed * (1.0 - frac) / frac);
  return bar;
}

void ProgressReporter::Update(int64_t done, int64_t total) {
  if (style_ == Style::kQuiet || !out_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_ || done < last_done_) return;
  const auto now = std::chrono::steady_clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double since = std::chrono::duration<double>(now - last_draw_).count();
  const bool complete = total > 0 && done >= total;
  total_ = total;
  if (style_ == Style::kBar) {
    if (!complete && since < 0.1 && drew_) return;
    std::fprintf(out_, "\r%s %s", label_.c_str(), FormatBar(done, total, elapsed, 30).c_str());
    if (complete) std::fputc('\n', out_), finished_ = true;
  } else {
    // Plain lines (logs): quiet for jobs under a second, then each 10 % or 5 s.
    const int decile = total > 0 ? int(10 * done / total) : 0;
    if (!complete && elapsed < 1.0 && !drew_) return;
    if (!complete && decile == last_decile_ && since < 5.0) return;
    last_decile_ = decile;
    std::fprintf(out_, "%s %s\n", label_.c_str(), FormatBar(done, total, elapsed, 20).c_str());
    if (complete) finished_ = true;
  }
  std::fflush(out_);
  last_draw_ = now;
  last_done_ = done;
  drew_ = true;
}

void ProgressReporter::Finish() {
  if (total_ > 0) Update(total_, total_);
}

ProgressFn ProgressReporter::Callback() {
  return [this](int64_t done, int64_t total) {
    Update(done, total);
    return true;
  };
}

}  // namespace matfit
