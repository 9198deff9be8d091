#include "leaf/segment.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "core/check.h"

namespace matfit::leaf {

const char* ComponentKindName(ComponentKind k) {
  switch (k) {
    case ComponentKind::kLeaf: return "leaf";
    case ComponentKind::kTwig: return "twig";
    case ComponentKind::kMarker: return "marker";
    case ComponentKind::kSpeck: return "speck";
  }
  return "?";
}

bool SegmentOptions::Check(std::string* why) const {
  auto fail = [&](const std::string& m) {
    if (why) *why = m;
    return false;
  };
  if (!(threshold > 0 && threshold < 1)) return fail("segmentation threshold must be in (0, 1)");
  if (min_area_px < 1) return fail("min_area_px must be ≥ 1");
  if (!(twig_elongation > 1)) return fail("twig_elongation must be > 1");
  if (!(marker_rectangularity > 0 && marker_rectangularity <= 1))
    return fail("marker_rectangularity must be in (0, 1]");
  if (!(marker_max_aspect >= 1)) return fail("marker_max_aspect must be ≥ 1");
  if (!(marker_max_chroma >= 0 && marker_max_chroma <= 1))
    return fail("marker_max_chroma must be in [0, 1]");
  if (open_radius < 0 || open_radius > 16) return fail("open_radius must be in 0..16");
  return true;
}

int Segmentation::leaves() const {
  return int(std::count_if(components.begin(), components.end(),
                           [](const Component& c) { return c.kind == ComponentKind::kLeaf; }));
}

Segmentation Segment(const Image& t, const SegmentOptions& o, const Image* color) {
  MATFIT_CHECK(o.Check(nullptr) && t.channels() >= 1);
  const int w = t.width(), h = t.height();
  cv::Mat bin(h, w, CV_8U);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const float v = t.At(0, y, x);
      bin.at<uint8_t>(y, x) = (std::isfinite(v) && v < o.threshold) ? 255 : 0;
    }
  // Opening removes stems, hairs and specks thinner than the element; no closing, which would
  // bridge neighbouring leaves (and real holes in a leaf stay holes).
  if (o.open_radius > 0) {
    const int k = 2 * o.open_radius + 1;
    const cv::Mat se = cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(k, k));
    cv::morphologyEx(bin, bin, cv::MORPH_OPEN, se);
  }
  cv::Mat lab, stats, cents;
  const int n = cv::connectedComponentsWithStats(bin, lab, stats, cents, 8, CV_32S);
  Segmentation s;
  s.width = w, s.height = h;
  s.labels.assign(size_t(w) * h, 0);
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) s.labels[size_t(y) * w + x] = lab.at<int32_t>(y, x);
  std::vector<Component> comps;
  for (int l = 1; l < n; ++l) {
    Component c;
    c.label = l;
    c.x0 = stats.at<int>(l, cv::CC_STAT_LEFT), c.y0 = stats.at<int>(l, cv::CC_STAT_TOP);
    c.x1 = c.x0 + stats.at<int>(l, cv::CC_STAT_WIDTH) - 1;
    c.y1 = c.y0 + stats.at<int>(l, cv::CC_STAT_HEIGHT) - 1;
    c.area_px = stats.at<int>(l, cv::CC_STAT_AREA);
    c.cx = cents.at<double>(l, 0), c.cy = cents.at<double>(l, 1);
    c.touches_border = c.x0 == 0 || c.y0 == 0 || c.x1 == w - 1 || c.y1 == h - 1;
    // Shape from the outer contour (holes filled: a marker's inner pattern does not count).
    // On the component's bounding box only (one pass over the image in all).
    const cv::Rect box(c.x0, c.y0, c.x1 - c.x0 + 1, c.y1 - c.y0 + 1);
    cv::Mat m = (lab(box) == l);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(m, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE, cv::Point(c.x0, c.y0));
    double filled = 0;
    std::vector<cv::Point> all;
    for (const auto& ct : contours) {
      filled += cv::contourArea(ct);
      all.insert(all.end(), ct.begin(), ct.end());
    }
    if (!all.empty()) {
      const cv::RotatedRect rr = cv::minAreaRect(all);
      const double a = std::max(rr.size.width, rr.size.height) + 1;
      const double b = std::min(rr.size.width, rr.size.height) + 1;
      c.elongation = a / b;
      c.rectangularity = std::min(1.0, std::max(filled, double(c.area_px)) / (a * b));
      c.side_px = 0.5 * (a + b);
      // Corners: the convex hull simplified to 4 % of its perimeter.
      std::vector<cv::Point> hull, poly;
      cv::convexHull(all, hull);
      cv::approxPolyDP(hull, poly, 0.04 * cv::arcLength(hull, true), true);
      c.corners = int(poly.size());
    }
    if (color && color->channels() >= 3) {
      // Σ (max − min) / Σ max: a ratio of sums, so that dark, noisy pixels weigh little.
      double spread = 0, level = 0;
      for (int y = c.y0; y <= c.y1; ++y)
        for (int x = c.x0; x <= c.x1; ++x) {
          if (lab.at<int32_t>(y, x) != l) continue;
          const float r = color->At(0, y, x), g = color->At(1, y, x), b = color->At(2, y, x);
          spread += std::max({r, g, b}) - std::min({r, g, b}), level += std::max({r, g, b});
        }
      c.chroma = level > 0 ? spread / level : 0;
    }
    // Without a colour photo the colour test is unavailable: demand a fuller square instead.
    const bool achromatic = c.chroma >= 0 ? c.chroma <= o.marker_max_chroma
                                          : c.rectangularity >= o.marker_rectangularity_grey;
    if (c.area_px < o.min_area_px) {
      c.kind = ComponentKind::kSpeck;
    } else if (c.elongation >= o.twig_elongation) {
      c.kind = ComponentKind::kTwig;
    } else if (c.rectangularity >= o.marker_rectangularity && c.elongation <= o.marker_max_aspect &&
               c.corners == 4 && achromatic) {
      c.kind = ComponentKind::kMarker;
    } else {
      c.kind = ComponentKind::kLeaf;
    }
    comps.push_back(c);
  }
  // Stable ids: reading order (rows of the median leaf height, then left to right).
  std::vector<int> heights;
  for (const auto& c : comps)
    if (c.kind == ComponentKind::kLeaf) heights.push_back(c.y1 - c.y0 + 1);
  double band = 1;
  if (!heights.empty()) {
    std::nth_element(heights.begin(), heights.begin() + heights.size() / 2, heights.end());
    band = std::max(1, heights[heights.size() / 2]);
  }
  auto rank = [&](const Component& c) {
    return std::make_tuple(int(c.kind), int(std::floor(c.cy / band)), c.cx, c.cy);
  };
  std::sort(comps.begin(), comps.end(),
            [&](const Component& a, const Component& b) { return rank(a) < rank(b); });
  int next = 1;
  for (auto& c : comps)
    if (c.kind == ComponentKind::kLeaf) c.id = next++;
  s.components = std::move(comps);
  return s;
}

}  // namespace matfit::leaf
