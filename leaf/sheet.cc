#include "leaf/sheet.h"
#include "core/warnings.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

namespace matfit::leaf {

bool SheetOptions::Check(std::string* why) const {
  if (!segment.Check(why) || !background.Check(why)) return false;
  if (back_margin_px < 0 || back_margin_px > 64 || top_margin_px < 0 || top_margin_px > 64) {
    if (why) *why = "background margins must be in 0..64 pixels";
    return false;
  }
  if (!(saturation > 0 && saturation <= 1)) {
    if (why) *why = "saturation level must be in (0, 1]";
    return false;
  }
  return true;
}

Image Luminance(const Image& rgb) {
  if (rgb.channels() < 3) return rgb;
  Image l(rgb.width(), rgb.height(), 1);
  for (int64_t i = 0; i < rgb.plane_size(); ++i)
    l.Plane(0)[i] =
        0.2126f * rgb.Plane(0)[i] + 0.7152f * rgb.Plane(1)[i] + 0.0722f * rgb.Plane(2)[i];
  return l;
}

namespace {

// Pixels at least `margin` away from any non-background label.
std::vector<uint8_t> BareSheet(const std::vector<int32_t>& labels, int w, int h, int margin) {
  cv::Mat obj(h, w, CV_8U);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) obj.at<uint8_t>(y, x) = labels[size_t(y) * w + x] ? 255 : 0;
  if (margin > 0) {
    const cv::Mat se =
        cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(2 * margin + 1, 2 * margin + 1));
    cv::dilate(obj, obj, se);
  }
  std::vector<uint8_t> bg(size_t(w) * h);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) bg[size_t(y) * w + x] = obj.at<uint8_t>(y, x) == 0;
  return bg;
}

// Fused transmission: per channel Σ_k I_k / Σ_k B_k over the unclipped samples (a ratio of sums
// weighs each image by its back light: bright, well-exposed shots count most).
Status FuseBack(const LeafScan& scan, const std::vector<uint8_t>& bg, const SheetOptions& o,
                SheetAnalysis* a) {
  const int w = a->width, h = a->height, c3 = 3;
  const int64_t n = int64_t(w) * h;
  std::vector<double> num(size_t(c3) * n, 0.0), den(size_t(c3) * n, 0.0);
  a->back_rms_log = 0, a->saturated_back_samples = 0;
  for (size_t k = 0; k < scan.back.size(); ++k) {
    const Image& img = scan.back[k];
    // Each channel of the file once; a grey image feeds all three.
    for (int sc = 0; sc < std::min(img.channels(), c3); ++sc) {
      auto fit = FitBackground(img.Plane(sc), w, h, bg, o.background);
      if (!fit.ok())
        return DataError("back-lit image '" + scan.back_files[k] + "': " + fit.status().message());
      a->back_rms_log = std::max(a->back_rms_log, fit->rms_log);
      const std::span<const float> p = img.Plane(sc), b = fit->level.Plane(0);
      const int c_end = img.channels() == 1 ? c3 : sc + 1;
      for (int64_t i = 0; i < n; ++i) {
        if (!(p[i] < o.saturation)) {
          ++a->saturated_back_samples;
          continue;
        }
        for (int c = sc; c < c_end; ++c) num[c * n + i] += p[i], den[c * n + i] += b[i];
      }
    }
  }
  a->transmission = Image(w, h, c3);
  for (int c = 0; c < c3; ++c)
    for (int64_t i = 0; i < n; ++i)
      a->transmission.Plane(c)[i] =
          den[c * n + i] > 0 ? float(std::clamp(num[c * n + i] / den[c * n + i], 0.0, 4.0)) : 1.0f;
  a->luminance = Luminance(a->transmission);
  return Status::Ok();
}

}  // namespace

namespace {

// `top` is the scan's top-lit stack, by value: copied or moved in by the callers below.
StatusOr<SheetAnalysis> Analyze(const LeafScan& scan, LightStack top, const SheetOptions& o,
                                const ProgressFn& progress) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument("sheet options: " + why);
  if (scan.back.empty()) return DataError("the leaf scan has no back-lit images");
  SheetAnalysis a;
  a.width = scan.width(), a.height = scan.height();
  const int64_t steps = 3 + top.num_images();
  auto tick = [&](int64_t done) { return !progress || progress(done, steps); };
  const Status cancelled(StatusCode::kCancelled, "cancelled");
  const int w = a.width, h = a.height;
  const int64_t n = int64_t(w) * h;
  // 1. First guess: back-lit luminance over its bright level (90th percentile ≈ bare sheet).
  Image first(w, h, 1);
  {
    Image sum(w, h, 1);
    for (const Image& b : scan.back) {
      const Image l = Luminance(b);
      for (int64_t i = 0; i < n; ++i) sum.Plane(0)[i] += l.Plane(0)[i];
    }
    std::vector<float> v(sum.data().begin(), sum.data().end());
    std::nth_element(v.begin(), v.begin() + v.size() * 9 / 10, v.end());
    const float p90 = std::max(v[v.size() * 9 / 10], 1e-6f);
    for (int64_t i = 0; i < n; ++i) first.Plane(0)[i] = sum.Plane(0)[i] / p90;
  }
  // Colour photo for the marker test: the mean top-lit image, or the front-lit photo.
  Image color;
  if (top.num_images() > 0 && top.channels() >= 3) {
    color = Image(w, h, 3);
    std::vector<float> scratch(top.is_float() ? 0 : size_t(n));
    for (int m = 0; m < top.num_images(); ++m)
      for (int c = 0; c < 3; ++c) {
        const float* p = top.Texels(m, c, 0, int(n), scratch.data());
        for (int64_t i = 0; i < n; ++i) color.Plane(c)[i] += p[i];
      }
  } else if (scan.front.channels() >= 3) {
    color = scan.front;
  }
  const Image* colorp = color.empty() ? nullptr : &color;
  Segmentation seg = Segment(first, o.segment, colorp);
  if (!tick(1)) return cancelled;
  // 2. Twice: background from the bare sheet → fused transmission → segmentation.
  for (int round = 0; round < 2; ++round) {
    a.background = BareSheet(seg.labels, w, h, o.back_margin_px);
    MATFIT_RETURN_IF_ERROR(FuseBack(scan, a.background, o, &a));
    seg = Segment(a.luminance, o.segment, colorp);
    if (!tick(2 + round)) return cancelled;
  }
  a.segmentation = std::move(seg);
  if (a.saturated_back_samples > 0)
    a.warnings.push_back(
        Warning(WarningCode::kSaturatedBacklight,
                std::to_string(a.saturated_back_samples) +
                    " clipped back-lit samples were left out of the fused transmission"));
  // 3. Top-lit images (or the front-lit photo) over the bare sheet's brightness.
  const auto top_bg = BareSheet(a.segmentation.labels, w, h, o.top_margin_px);
  if (top.num_images() > 0) {
    // Flat-fielded in place below: the result is no longer file codes, so float32.
    a.top = top.is_float() ? std::move(top) : top.ToFloat();
    const int ch = a.top.channels();
    for (int m = 0; m < a.top.num_images(); ++m) {
      const double cos_t = std::max(0.05, a.top.lights()[m].direction.z);
      for (int c = 0; c < ch; ++c) {
        auto fit = FitBackground(a.top.Plane(m, c), w, h, top_bg, o.background);
        if (!fit.ok()) {
          const std::string f = m < int(a.top.image_files.size()) ? a.top.image_files[m] : "?";
          return DataError("top-lit image '" + f + "': " + fit.status().message());
        }
        a.top_rms_log = std::max(a.top_rms_log, fit->rms_log);
        auto p = a.top.Plane(m, c);
        const auto b = fit->level.Plane(0);
        // Clipped samples stay marked as clipped (1 ≥ fit/'s clip level) so that photometric
        // stereo drops them; a flat-fielded unclipped sample is ρ (n·l) < 1.
        for (int64_t i = 0; i < n; ++i)
          p[i] = p[i] >= o.saturation
                     ? 1.0f
                     : std::min(0.999f, float(p[i] / std::max(b[i], 1e-6f) * cos_t));
      }
      if (!tick(4 + m)) return cancelled;
    }
  } else if (!scan.front.empty()) {
    a.front = scan.front;
    for (int c = 0; c < a.front.channels(); ++c) {
      auto fit = FitBackground(a.front.Plane(c), w, h, top_bg, o.background);
      if (!fit.ok())
        return DataError("front-lit photo '" + scan.front_file + "': " + fit.status().message());
      a.top_rms_log = std::max(a.top_rms_log, fit->rms_log);
      auto p = a.front.Plane(c);
      const auto b = fit->level.Plane(0);
      for (int64_t i = 0; i < n; ++i) p[i] = p[i] / std::max(b[i], 1e-6f);
    }
  }
  return a;
}

}  // namespace

StatusOr<SheetAnalysis> AnalyzeSheet(const LeafScan& scan, const SheetOptions& o,
                                     const ProgressFn& progress) {
  return Analyze(scan, scan.top, o, progress);
}

StatusOr<SheetAnalysis> AnalyzeSheet(LeafScan* scan, const SheetOptions& o,
                                     const ProgressFn& progress) {
  LightStack top = std::move(scan->top);
  scan->top = LightStack();
  return Analyze(*scan, std::move(top), o, progress);
}

}  // namespace matfit::leaf
