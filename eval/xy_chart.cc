// XYChartSvg: scatter / line charts with linear or log axes, legend and Pareto front.
#include "eval/chart.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numeric>
#include <string_view>
#include <utility>

#include "eval/svg_util.h"

namespace matfit::eval {

using namespace svg;  // NOLINT: the building blocks of this module

// ---------------------------------------------------------------------------------------------
// XY chart.

namespace {

struct Box {
  double x0, y0, x1, y1;
};

double OverlapArea(const Box& a, const Box& b) {
  const double w = std::min(a.x1, b.x1) - std::max(a.x0, b.x0);
  const double h = std::min(a.y1, b.y1) - std::max(a.y0, b.y0);
  return w > 0 && h > 0 ? w * h : 0;
}

// Labelled axis: pixel mapping, labelled ticks and grid-only ticks.
struct Axis {
  AxisMap map;
  std::vector<double> major, minor;
};

// `spacing`: desired pixels between automatic ticks.
Axis MakeAxis(double lo, double hi, bool have_data, bool log, double p0, double p1, double spacing,
              const std::vector<double>& explicit_ticks) {
  Axis axis;
  std::vector<double> fixed;
  for (double t : explicit_ticks) {
    if (Usable(t, log)) fixed.push_back(t);
  }
  if (!fixed.empty()) {  // widen the data range to show every requested tick
    const auto [mn, mx] = std::minmax_element(fixed.begin(), fixed.end());
    lo = have_data ? std::min(lo, *mn) : *mn;
    hi = have_data ? std::max(hi, *mx) : *mx;
    have_data = true;
  }
  PadRange(lo, hi, log, have_data);
  axis.map = {lo, hi, p0, p1, log};
  const int target = std::max(2, static_cast<int>(std::fabs(p1 - p0) / spacing));
  axis.major = fixed.empty() ? AutoTicks(lo, hi, log, target) : TicksInRange(fixed, lo, hi);
  if (fixed.empty()) {
    for (double m : MinorTicks(lo, hi, log, target)) {
      if (!std::binary_search(axis.major.begin(), axis.major.end(), m)) axis.minor.push_back(m);
    }
  }
  return axis;
}

struct LegendEntry {
  std::string label;
  std::string colour;
  int shape;  // -1: Pareto ring
  bool line, markers, dashed;
};

}  // namespace

std::string XYChartSvg(const XYChart& chart) {
  const double width = std::max(chart.width, 240);
  const double height = std::max(chart.height, 180);
  constexpr double kTickFont = 11, kLabelFont = 13, kTitleFont = 16, kPointFont = 10;

  // Data ranges over the drawable points.
  double xlo = std::numeric_limits<double>::infinity(), xhi = -xlo, ylo = xlo, yhi = -xlo;
  bool have = false;
  for (const Series& s : chart.series) {
    const size_t n = std::min(s.x.size(), s.y.size());
    for (size_t i = 0; i < n; ++i) {
      if (!Usable(s.x[i], chart.log_x) || !Usable(s.y[i], chart.log_y)) continue;
      have = true;
      xlo = std::min(xlo, s.x[i]);
      xhi = std::max(xhi, s.x[i]);
      ylo = std::min(ylo, s.y[i]);
      yhi = std::max(yhi, s.y[i]);
    }
  }

  // Vertical layout first: the y tick labels decide the left margin.
  const double top = chart.title.empty() ? 16 : 42;
  const double bottom = height - (chart.x_label.empty() ? 30 : 52);
  const Axis yaxis = MakeAxis(ylo, yhi, have, chart.log_y, bottom, top, chart.log_y ? 35 : 45, {});
  double ytick_w = 0;
  for (double t : yaxis.major) ytick_w = std::max(ytick_w, TextWidth(FormatTick(t), kTickFont));
  const double left = 10 + (chart.y_label.empty() ? 0 : 22) + ytick_w + 8;
  const double right = width - 20;
  const Axis xaxis =
      MakeAxis(xlo, xhi, have, chart.log_x, left, right, chart.log_x ? 50 : 80, chart.x_ticks);
  const AxisMap& mx = xaxis.map;
  const AxisMap& my = yaxis.map;

  std::string body;
  // Plot area, grid lines (minor lighter than major), tick marks and tick labels.
  body += Rect(left, top, right - left, bottom - top, "class=\"plot-area\" fill=\"#ffffff\"");
  body += "<g stroke=\"#eeeeee\" stroke-width=\"1\">\n";
  for (double t : xaxis.minor) body += Line(mx(t), top, mx(t), bottom, "");
  for (double t : yaxis.minor) body += Line(left, my(t), right, my(t), "");
  body += "</g>\n<g stroke=\"#d0d0d0\" stroke-width=\"1\">\n";
  for (double t : xaxis.major) body += Line(mx(t), top, mx(t), bottom, "");
  for (double t : yaxis.major) body += Line(left, my(t), right, my(t), "");
  body += "</g>\n<g stroke=\"#444444\" stroke-width=\"1\">\n";
  for (double t : xaxis.major) body += Line(mx(t), bottom, mx(t), bottom + 4, "");
  for (double t : yaxis.major) body += Line(left - 4, my(t), left, my(t), "");
  body += "</g>\n";
  // Tick labels; a label that would overlap the previous drawn one is left out.
  const std::string tick_attr = "font-size=\"" + Num(kTickFont) + "\" fill=\"#333333\"";
  double last_right = -1e9;
  for (double t : xaxis.major) {
    const std::string label = FormatTick(t);
    const double w = TextWidth(label, kTickFont), px = mx(t);
    if (px - w / 2 < last_right + 6) continue;
    last_right = px + w / 2;
    body +=
        Text(px, bottom + 17, label,
             "class=\"xtick\" text-anchor=\"middle\" data-value=\"" + Num(t) + "\" " + tick_attr);
  }
  double last_top = 1e9;
  for (double t : yaxis.major) {  // increasing values: upwards on screen
    const double py = my(t);
    if (py + kTickFont * 0.5 > last_top - 2) continue;
    last_top = py - kTickFont * 0.5;
    body += Text(left - 7, py + kTickFont * 0.35, FormatTick(t),
                 "class=\"ytick\" text-anchor=\"end\" data-value=\"" + Num(t) + "\" " + tick_attr);
  }

  // Series: lines first (all series), then markers, so markers stay visible on top of lines.
  std::vector<LegendEntry> legend;
  struct Pt {
    double px, py;
    bool ok;
  };
  std::vector<Pt> flat;  // all points of all series, flattened as documented for `pareto`
  std::vector<std::vector<Pt>> pts(chart.series.size());
  for (size_t si = 0; si < chart.series.size(); ++si) {
    const Series& s = chart.series[si];
    const size_t n = std::min(s.x.size(), s.y.size());
    for (size_t i = 0; i < n; ++i) {
      const bool ok = Usable(s.x[i], chart.log_x) && Usable(s.y[i], chart.log_y);
      pts[si].push_back({ok ? mx(s.x[i]) : 0, ok ? my(s.y[i]) : 0, ok});
      flat.push_back(pts[si].back());
    }
  }
  auto colour_of = [](size_t si) { return Hex(FromHex(kPalette[si % kPalette.size()])); };
  auto shape_of = [](size_t si) { return static_cast<int>(si / kPalette.size()) % kNumShapes; };

  for (size_t si = 0; si < chart.series.size(); ++si) {
    if (!chart.series[si].line) continue;
    // Polyline broken at skipped points: each run of usable points is its own subpath.
    std::string d;
    bool pen_down = false;
    for (const Pt& p : pts[si]) {
      if (!p.ok) {
        pen_down = false;
        continue;
      }
      d += (pen_down ? " L" : (d.empty() ? "M" : " M")) + Px(p.px) + "," + Px(p.py);
      pen_down = true;
    }
    if (d.empty()) continue;
    body += "<path class=\"series-line\" d=\"" + d + "\" fill=\"none\" stroke=\"" + colour_of(si) +
            "\" stroke-width=\"1.8\" stroke-linejoin=\"round\"/>\n";
  }

  // Pareto front: a staircase through the front points sorted by x (horizontal then vertical
  // steps, i.e. the boundary of the region they dominate).
  std::vector<std::pair<double, double>> front;
  for (size_t idx : chart.pareto) {
    if (idx < flat.size() && flat[idx].ok) front.emplace_back(flat[idx].px, flat[idx].py);
  }
  std::sort(front.begin(), front.end(), [](const auto& a, const auto& b) {
    return a.first != b.first ? a.first < b.first : a.second > b.second;  // larger y first
  });
  if (!front.empty()) {
    std::string d = "M" + Px(front[0].first) + "," + Px(front[0].second);
    for (size_t i = 1; i < front.size(); ++i) {
      d += " L" + Px(front[i].first) + "," + Px(front[i - 1].second) + " L" + Px(front[i].first) +
           "," + Px(front[i].second);
    }
    body += "<path class=\"pareto-line\" d=\"" + d +
            "\" fill=\"none\" stroke=\"#222222\" stroke-width=\"1.5\" "
            "stroke-dasharray=\"6 4\"/>\n";
  }

  for (size_t si = 0; si < chart.series.size(); ++si) {
    const Series& s = chart.series[si];
    if (!s.markers) continue;
    body += "<g class=\"series-markers\" fill=\"" + colour_of(si) +
            "\" stroke=\"#ffffff\" stroke-width=\"0.8\">\n";
    for (const Pt& p : pts[si]) {
      if (p.ok) body += Marker(shape_of(si), p.px, p.py);
    }
    body += "</g>\n";
  }
  if (!front.empty()) {
    body += "<g class=\"pareto-markers\" fill=\"none\" stroke=\"#222222\" stroke-width=\"1.5\">\n";
    for (const auto& [px, py] : front) {
      body += "<circle cx=\"" + Px(px) + "\" cy=\"" + Px(py) + "\" r=\"7.5\"/>\n";
    }
    body += "</g>\n";
  }

  // Point labels: greedy placement. Each label tries six positions around its point and takes the
  // one with the least overlap with markers and earlier labels, preferring to stay in the plot.
  std::vector<Box> obstacles;
  for (const Pt& p : flat) {
    if (p.ok) obstacles.push_back({p.px - 5, p.py - 5, p.px + 5, p.py + 5});
  }
  std::string labels;
  for (size_t si = 0; si < chart.series.size(); ++si) {
    const Series& s = chart.series[si];
    for (size_t i = 0; i < pts[si].size() && i < s.point_labels.size(); ++i) {
      const Pt& p = pts[si][i];
      if (!p.ok || s.point_labels[i].empty()) continue;
      const double w = TextWidth(s.point_labels[i], kPointFont), asc = kPointFont * 0.8,
                   desc = kPointFont * 0.25;
      struct Cand {
        double dx, dy;  // baseline anchor offset
        bool start;     // text-anchor start (else end)
      };
      static constexpr Cand kCands[] = {{7, -6, true},   {7, 13, true},  {-7, -6, false},
                                        {-7, 13, false}, {8, 3.5, true}, {-8, 3.5, false}};
      double best_score = std::numeric_limits<double>::infinity();
      Cand best = kCands[0];
      Box best_box{};
      for (const Cand& c : kCands) {
        const double bx = p.px + c.dx, by = p.py + c.dy;
        const Box b{c.start ? bx : bx - w, by - asc, c.start ? bx + w : bx, by + desc};
        double score = 0;
        for (const Box& o : obstacles) score += OverlapArea(b, o);
        const Box plot{left, top, right, bottom};
        score += 100 * ((b.x1 - b.x0) * (b.y1 - b.y0) - OverlapArea(b, plot));  // outside
        if (score < best_score) {
          best_score = score;
          best = c;
          best_box = b;
        }
      }
      obstacles.push_back(best_box);
      labels += Text(p.px + best.dx, p.py + best.dy, s.point_labels[i],
                     std::string("class=\"point-label\" text-anchor=\"") +
                         (best.start ? "start" : "end") + "\" font-size=\"" + Num(kPointFont) +
                         "\" fill=\"#333333\"");
    }
  }
  body += labels;

  if (!have) {
    body += Text((left + right) / 2, (top + bottom) / 2, "no data",
                 "class=\"no-data\" text-anchor=\"middle\" font-size=\"14\" font-style=\"italic\" "
                 "fill=\"#888888\"");
  }
  body += Rect(left, top, right - left, bottom - top,
               "class=\"plot-frame\" fill=\"none\" stroke=\"#444444\" stroke-width=\"1\"");

  // Title and axis labels.
  if (!chart.title.empty()) {
    body += Text((left + right) / 2, 26, chart.title,
                 "class=\"title\" text-anchor=\"middle\" font-size=\"" + Num(kTitleFont) +
                     "\" font-weight=\"bold\"");
  }
  if (!chart.x_label.empty()) {
    body += Text((left + right) / 2, bottom + 40, chart.x_label,
                 "class=\"x-label\" text-anchor=\"middle\" font-size=\"" + Num(kLabelFont) + "\"");
  }
  if (!chart.y_label.empty()) {
    const double x = 10 + kLabelFont, y = (top + bottom) / 2;
    body += Text(x, y, chart.y_label,
                 "class=\"y-label\" text-anchor=\"middle\" font-size=\"" + Num(kLabelFont) +
                     "\" transform=\"rotate(-90 " + Px(x) + " " + Px(y) + ")\"");
  }

  // Legend, to the right of the plot area (the SVG is widened to make room).
  for (size_t si = 0; si < chart.series.size(); ++si) {
    const Series& s = chart.series[si];
    if (s.label.empty()) continue;
    legend.push_back({s.label, colour_of(si), shape_of(si), s.line, s.markers, false});
  }
  if (!front.empty()) legend.push_back({"Pareto front", "#222222", -1, true, true, true});
  double total_w = width, total_h = height;
  if (!legend.empty()) {
    constexpr double kPad = 8, kRow = 18, kSample = 28, kFont = 12;
    double text_w = 0;
    for (const LegendEntry& e : legend) text_w = std::max(text_w, TextWidth(e.label, kFont));
    const double lx = right + 24, ly = top;
    const double lw = kPad + kSample + 6 + text_w + kPad;
    const double lh = kPad + kRow * static_cast<double>(legend.size()) + kPad / 2;
    body += Rect(lx, ly, lw, lh,
                 "class=\"legend\" fill=\"#ffffff\" stroke=\"#999999\" stroke-width=\"1\"");
    for (size_t i = 0; i < legend.size(); ++i) {
      const LegendEntry& e = legend[i];
      const double cy = ly + kPad + kRow * (static_cast<double>(i) + 0.5);
      const double sx = lx + kPad;
      if (e.line) {
        body += Line(sx, cy, sx + kSample, cy,
                     "stroke=\"" + e.colour + "\" stroke-width=\"" + (e.dashed ? "1.5" : "1.8") +
                         "\"" + (e.dashed ? " stroke-dasharray=\"6 4\"" : ""));
      }
      if (e.shape < 0) {
        body += "<circle cx=\"" + Px(sx + kSample / 2) + "\" cy=\"" + Px(cy) +
                "\" r=\"6\" fill=\"#ffffff\" stroke=\"#222222\" stroke-width=\"1.5\"/>\n";
      } else if (e.markers) {
        body += "<g fill=\"" + e.colour + "\" stroke=\"#ffffff\" stroke-width=\"0.8\">\n" +
                Marker(e.shape, sx + kSample / 2, cy) + "</g>\n";
      }
      body += Text(sx + kSample + 6, cy + kFont * 0.35, e.label,
                   "class=\"legend-label\" font-size=\"" + Num(kFont) + "\"");
    }
    total_w = lx + lw + 12;
    total_h = std::max(total_h, ly + lh + 12);
  }

  return SvgOpen(total_w, total_h, chart.title) + body + "</svg>\n";
}

}  // namespace matfit::eval
