// Pieces shared by the fitting methods (not part of the public fit API).
#pragma once

#include <algorithm>
#include <chrono>
#include <vector>

#include "core/light_stack.h"
#include "core/status.h"
#include "core/tiles.h"
#include "fit/fit_types.h"
#include "fit/row_kernels.h"

namespace matfit::fit {

// 1 / I_{i,c}, index i * C + c: every method divides samples by the light's intensity.
std::vector<float> InverseIntensities(const LightStack& stack);

// Allocates result.maps of the model named `model` (core/model registry; normal 3, albedo 3,
// mask) and the status plane with masked texels marked.
void InitResult(const LightStack& stack, std::string_view model, const std::string& method,
                FitResult* result);

// InitResult for seed method A: also ambient (3 planes) and normal_scale (1).
void InitHeinrichResult(const LightStack& stack, const std::string& method, FitResult* result);

// Samples at or above this linear value sit at the maximum code of an integer file.
inline constexpr float kClipLevel = 0.9999f;
// True when decoding found pixels at the maximum code (LightStack::saturated_pixels).
bool StackMayBeClipped(const LightStack& stack);
// A texel whose samples all stay at or below this (linear) carries no signal.
inline constexpr float kNoSignalLevel = 1e-6f;
// Before fitting: texels black in every image → kTexelNoSignal; with flag_clipped, texels with
// any sample at the file's maximum code → kTexelSaturated (no-op for unclipped stacks).
void MarkUnfittableTexels(const LightStack& stack, bool flag_clipped, FitResult* result);

// Fused form of MarkUnfittableTexels for one strip, from the per-texel maximum sample that the
// row kernels collect (peak, m texels starting at plane index first): ok texels with
// peak ≤ kNoSignalLevel → kTexelNoSignal; with clip (see StackMayBeClipped), peak ≥ kClipLevel →
// kTexelSaturated.
void ApplyPeakStatus(const float* peak, int64_t first, int64_t m, bool clip, uint8_t* status);

// Runs fn(tile) over full-width strips of ≈ tile² texels with ParallelFor; reports progress; false
// if cancelled.
bool ForEachTile(const LightStack& stack, const FitOptions& options,
                 const std::function<void(const Tile&)>& fn);

// Plane segments of a strip for the row kernels, from any stack. Group(i0, planes, c, first, m,
// fn) hands fn(src, x, len) the samples of images i0 … i0 + planes − 1 (≤ kMaxRowPlanes),
// channel c, texels [first + x, first + x + len) as linear floats: for float stacks once, x = 0,
// len = m, pointing into the planes; for native-depth stacks in chunks of kChunk texels decoded
// through the table into scratch (kMaxRowPlanes × kChunk floats, L1/L2-sized). Every texel gets
// the same samples in the same order either way, so kernel results are identical.
class StripReader {
 public:
  static constexpr int kChunk = 1024;
  explicit StripReader(const LightStack& stack) : s_(stack) {
    if (!stack.is_float()) scratch_.resize(size_t(kMaxRowPlanes) * kChunk);
  }
  template <typename Fn>
  void Group(int i0, int planes, int c, int64_t first, int64_t m, Fn&& fn) {
    const float* src[kMaxRowPlanes];
    if (s_.is_float()) {
      for (int q = 0; q < planes; ++q) src[q] = s_.Texels(i0 + q, c, first, int(m), nullptr);
      fn(src, int64_t(0), m);
      return;
    }
    for (int64_t x = 0; x < m; x += kChunk) {
      const int len = int(std::min<int64_t>(kChunk, m - x));
      for (int q = 0; q < planes; ++q)
        src[q] = s_.Texels(i0 + q, c, first + x, len, scratch_.data() + size_t(q) * kChunk);
      fn(src, x, int64_t(len));
    }
  }

 private:
  const LightStack& s_;
  std::vector<float> scratch_;
};

// Counts status entries other than ok/masked into result->flagged_texels and adds a warning
// naming the most common reason.
// With `bands`, a band of a distributed stack: the counts of every band (a collective).
void SummariseStatus(FitResult* result, const LightStack* bands = nullptr);
// The same after the status changed: the earlier summary warning is replaced.
void ResummariseStatus(FitResult* result, const LightStack* bands = nullptr);

// Common epilogue: cancelled → kCancelled; else summarise the status plane, stamp the time
// since t0 and return the result.
StatusOr<FitResult> FinishFit(bool completed, std::chrono::steady_clock::time_point t0,
                              FitResult r);

// Rec. 709 luminance weights for linear RGB (1 channel: weight 1).
inline constexpr float kLuma[3] = {0.2126f, 0.7152f, 0.0722f};

}  // namespace matfit::fit
