#include "fit/fit_common.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <map>
#include <mutex>

#include "core/model/model.h"
#include "core/parallel.h"
#include "core/stack_band.h"
#include "core/warnings.h"

namespace matfit::fit {

const char* TexelStatusName(uint8_t s) {
  switch (s) {
    case kTexelOk: return "ok";
    case kTexelMasked: return "masked";
    case kTexelNoSignal: return "no signal";
    case kTexelNonFinite: return "non-finite samples";
    case kTexelTooFewLights: return "too few usable lights";
    case kTexelIllConditioned: return "ill-conditioned lights";
    case kTexelSaturated: return "clipped samples";
    case kTexelUnverifiable: return "error cannot be bounded";
    case kTexelSuspectData: return "suspect data";
  }
  return "unknown";
}

bool FitOptions::Check(std::string* why) const {
  if (tile < 8 || tile > 4096) {
    *why = "--tile must be in [8, 4096], got " + std::to_string(tile);
    return false;
  }
  if (!(near_tolerance_deg > 0 && near_tolerance_deg <= 10)) {
    *why = "--near-tolerance must be in (0, 10] degrees, got " + std::to_string(near_tolerance_deg);
    return false;
  }
  if (!(robust_scale >= 0 && robust_scale <= 10)) {
    *why = "--robust-scale must be in [0, 10] (0 = least squares), got " +
           std::to_string(robust_scale);
    return false;
  }
  if (lobe_shape_texels < 0) {
    *why = "--lobe-shape-texels must be >= 0 (0 = every texel), got " +
           std::to_string(lobe_shape_texels);
    return false;
  }
  if (!(exponent_min >= 1 && exponent_max > exponent_min)) {
    *why = "exponent range must satisfy 1 ≤ min < max";
    return false;
  }
  return true;
}

std::vector<float> InverseIntensities(const LightStack& s) {
  std::vector<float> inv(size_t(s.num_images()) * s.channels());
  for (int i = 0; i < s.num_images(); ++i)
    for (int c = 0; c < s.channels(); ++c) {
      const double I = s.channels() == 1 ? (s.lights()[i].intensity.x + s.lights()[i].intensity.y +
                                            s.lights()[i].intensity.z) /
                                               3
                                         : s.lights()[i].intensity[c];
      inv[size_t(i) * s.channels() + c] = float(1.0 / I);
    }
  return inv;
}

void InitHeinrichResult(const LightStack& s, const std::string& method, FitResult* r) {
  InitResult(s, "heinrich", method, r);
  r->maps.ambient = Image(s.width(), s.height(), 3);
  r->maps.normal_scale = Image(s.width(), s.height(), 1);
}

void InitResult(const LightStack& s, std::string_view model, const std::string& method,
                FitResult* r) {
  r->method = method;
  r->maps = {};
  r->maps.width = s.width();
  r->maps.height = s.height();
  r->maps.model = ModelId(model);
  r->maps.normal = Image(s.width(), s.height(), 3);
  r->maps.albedo = Image(s.width(), s.height(), 3);
  r->maps.mask = Image(s.width(), s.height(), 1, 1.0f);
  r->status.assign(size_t(s.plane_size()), kTexelOk);
  if (s.has_mask())
    for (int64_t p = 0; p < s.plane_size(); ++p)
      if (!s.mask[p]) r->status[p] = kTexelMasked, r->maps.mask.data()[p] = 0.0f;
}

bool StackMayBeClipped(const LightStack& s) {
  for (int64_t v : s.saturated_pixels)
    if (v > 0) return true;
  return false;
}

void MarkUnfittableTexels(const LightStack& s, bool flag_clipped, FitResult* r) {
  const bool clip = flag_clipped && StackMayBeClipped(s);
  const int W = s.width();
  ParallelFor(0, s.height(), [&](int64_t y0, int64_t y1) {
    std::vector<char> hit(W);
    std::vector<float> peak(W), scratch(s.is_float() ? 0 : W);
    for (int64_t y = y0; y < y1; ++y) {
      std::fill(hit.begin(), hit.end(), 0);
      std::fill(peak.begin(), peak.end(), 0.0f);
      for (int i = 0; i < s.num_images(); ++i)
        for (int c = 0; c < s.channels(); ++c) {
          const float* src = s.Row(i, c, int(y), 0, W, scratch.data());
          for (int x = 0; x < W; ++x) {
            peak[x] = std::max(peak[x], src[x]);  // NaN samples leave peak unchanged
            hit[x] |= clip && src[x] >= kClipLevel;
          }
        }
      for (int x = 0; x < W; ++x) {
        uint8_t& st = r->status[y * W + x];
        if (st != kTexelOk) continue;
        if (!(peak[x] > kNoSignalLevel))
          st = kTexelNoSignal;
        else if (hit[x])
          st = kTexelSaturated;
      }
    }
  });
}

void ApplyPeakStatus(const float* peak, int64_t first, int64_t m, bool clip, uint8_t* status) {
  for (int64_t k = 0; k < m; ++k) {
    uint8_t& st = status[first + k];
    if (st != kTexelOk) continue;
    if (!(peak[k] > kNoSignalLevel))
      st = kTexelNoSignal;
    else if (clip && peak[k] >= kClipLevel)
      st = kTexelSaturated;
  }
}

bool ForEachTile(const LightStack& s, const FitOptions& o,
                 const std::function<void(const Tile&)>& fn) {
  // Work units of about tile² texels, as full-width strips (contiguous plane rows).
  const int rows = std::max(1, int(int64_t(o.tile) * o.tile / std::max(1, s.width())));
  const std::vector<Tile> tiles = MakeRowStrips(s.width(), s.height(), rows);
  std::atomic<int64_t> done{0};
  std::atomic<bool> cancelled{false};
  std::mutex progress_mutex;
  ParallelFor(0, int64_t(tiles.size()), [&](int64_t b, int64_t e) {
    for (int64_t t = b; t < e && !cancelled; ++t) {
      fn(tiles[t]);
      const int64_t d = ++done;
      if (o.progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        if (!o.progress(d, int64_t(tiles.size()))) cancelled = true;
      }
    }
  });
  return !cancelled;
}

void SummariseStatus(FitResult* r, const LightStack* bands) {
  std::array<int64_t, 256> counts{};
  for (uint8_t s : r->status)
    if (s != kTexelOk && s != kTexelMasked) ++counts[s];
  if (bands) SumOverBands(*bands, counts.data(), int(counts.size()));
  r->flagged_texels = 0;
  int most = 0;  // the most common reason (the lowest code among equals)
  for (int s = 0; s < 256; ++s) {
    r->flagged_texels += counts[size_t(s)];
    if (counts[size_t(s)] > counts[size_t(most)]) most = s;
  }
  if (r->flagged_texels > 0)
    r->warnings.push_back(Warning(WarningCode::kFlaggedTexels, std::to_string(r->flagged_texels) +
                                                                   " texel(s) flagged, mostly '" +
                                                                   TexelStatusName(uint8_t(most)) +
                                                                   "'; see the status map"));
}

void ResummariseStatus(FitResult* r, const LightStack* bands) {
  r->warnings.erase(std::remove_if(r->warnings.begin(), r->warnings.end(),
                                   [](const std::string& w) {
                                     return w.find(" texel(s) flagged, mostly '") !=
                                            std::string::npos;
                                   }),
                    r->warnings.end());
  SummariseStatus(r, bands);
}

StatusOr<FitResult> FinishFit(bool completed, std::chrono::steady_clock::time_point t0,
                              FitResult r) {
  if (!completed) return Status(StatusCode::kCancelled, r.method + ": fit cancelled");
  SummariseStatus(&r);
  r.fit_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return r;
}

}  // namespace matfit::fit
