// HeatMapSvg: a method × case grid coloured on a sequential scale, with a colour bar.
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
// Heat map.

namespace {

// FNV-1a, to give gradient/pattern ids that do not clash when several maps share an HTML page.
uint64_t Fnv(uint64_t h, std::string_view s) {
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::string HexId(uint64_t h) {
  static const char kDigits[] = "0123456789abcdef";
  std::string s;
  for (int i = 0; i < 8; ++i) s += kDigits[(h >> (4 * i)) & 15];
  return s;
}

}  // namespace

std::string HeatMapSvg(const HeatMap& map) {
  constexpr double kFont = 11, kLabelFont = 13, kTitleFont = 16;
  const size_t nr = map.rows.size(), nc = map.cols.size();
  const double cw = std::max(map.cell_width, 12), ch = std::max(map.cell_height, 12);

  if (nr == 0 || nc == 0) {
    const double w = std::max(300.0, TextWidth(map.title, kTitleFont) + 40), h = 120;
    std::string body;
    if (!map.title.empty()) {
      body += Text(w / 2, 26, map.title,
                   "class=\"title\" text-anchor=\"middle\" font-size=\"16\" font-weight=\"bold\"");
    }
    body += Text(w / 2, 75, "no data",
                 "class=\"no-data\" text-anchor=\"middle\" font-size=\"14\" font-style=\"italic\" "
                 "fill=\"#888888\"");
    return SvgOpen(w, h, map.title) + body + "</svg>\n";
  }

  // Colour scale t(v) = (f(v) - f(lo)) / (f(hi) - f(lo)) clamped to [0, 1], f = identity or log10.
  double lo = map.vmin, hi = map.vmax;
  double data_min = std::numeric_limits<double>::infinity(), data_max = -data_min;
  double min_pos = data_min;
  for (double v : map.values) {
    if (!std::isfinite(v)) continue;
    data_min = std::min(data_min, v);
    data_max = std::max(data_max, v);
    if (v > 0) min_pos = std::min(min_pos, v);
  }
  if (!std::isfinite(lo)) lo = std::isfinite(data_min) ? data_min : 0;
  if (!std::isfinite(hi)) hi = std::isfinite(data_max) ? data_max : 1;
  if (hi < lo) std::swap(lo, hi);
  const bool log = map.log_scale;
  if (log) {
    if (!(hi > 0)) hi = std::isfinite(data_max) && data_max > 0 ? data_max : 1;
    if (!(lo > 0)) lo = std::isfinite(min_pos) && min_pos < hi ? min_pos : hi / 1000;
    if (!(hi > lo)) hi = lo * 10;
  } else if (!(hi > lo)) {
    const double pad = lo == 0 ? 0.5 : 0.05 * std::fabs(lo);
    lo -= pad;
    hi += pad;
  }
  auto scale_t = [&](double v) {
    if (log) v = std::max(v, lo);
    const double f = log ? std::log10(v) : v;
    const double a = log ? std::log10(lo) : lo, b = log ? std::log10(hi) : hi;
    return std::clamp((f - a) / (b - a), 0.0, 1.0);
  };

  // Layout: title, column-axis title, rotated column labels, then the grid; row labels left.
  double y = 10;
  if (!map.title.empty()) y = 40;
  const double col_title_y = y + kLabelFont;
  if (!map.col_label.empty()) y += 22;
  double col_w = 0, row_w = 0;
  for (const std::string& c : map.cols) col_w = std::max(col_w, TextWidth(c, kFont));
  for (const std::string& r : map.rows) row_w = std::max(row_w, TextWidth(r, kFont));
  constexpr double kSin45 = 0.70710678118654752;
  const double grid_top = y + col_w * kSin45 + kFont + 8;
  const double grid_left = 10 + (map.row_label.empty() ? 0 : 24) + row_w + 8;
  const double grid_w = cw * static_cast<double>(nc), grid_h = ch * static_cast<double>(nr);
  const double grid_right = grid_left + grid_w;

  uint64_t h = 1469598103934665603ull;
  h = Fnv(h, map.title);
  for (const std::string& s : map.rows) h = Fnv(h, s);
  for (const std::string& s : map.cols) h = Fnv(h, s);
  for (double v : map.values) h = Fnv(h, Num(v, 17));
  const std::string id = HexId(h);
  const std::string hatch_id = "mf-hatch-" + id, grad_id = "mf-cbar-" + id;

  std::string body;
  body += "<defs>\n<pattern id=\"" + hatch_id +
          "\" patternUnits=\"userSpaceOnUse\" width=\"6\" height=\"6\">"
          "<rect x=\"0\" y=\"0\" width=\"6\" height=\"6\" fill=\"#e6e6e6\"/>"
          "<path d=\"M0,6 L6,0 M-1,1 L1,-1 M5,7 L7,5\" stroke=\"#aaaaaa\" stroke-width=\"1\"/>"
          "</pattern>\n";
  body += "<linearGradient id=\"" + grad_id + "\" x1=\"0\" y1=\"1\" x2=\"0\" y2=\"0\">\n";
  for (size_t i = 0; i < kViridis.size(); ++i) {
    body += "<stop offset=\"" + Num(static_cast<double>(i) / (kViridis.size() - 1), 4) +
            "\" stop-color=\"" + Hex(FromHex(kViridis[i])) + "\"/>\n";
  }
  body += "</linearGradient>\n</defs>\n";

  if (!map.title.empty()) {
    body += Text(10, 26, map.title,
                 "class=\"title\" font-size=\"" + Num(kTitleFont) + "\" font-weight=\"bold\"");
  }
  if (!map.col_label.empty()) {
    const double half = TextWidth(map.col_label, kLabelFont) / 2;
    body +=
        Text(std::max(grid_left + grid_w / 2, 10 + half), col_title_y, map.col_label,
             "class=\"col-label\" text-anchor=\"middle\" font-size=\"" + Num(kLabelFont) + "\"");
  }
  if (!map.row_label.empty()) {
    const double x = 10 + kLabelFont, cy = grid_top + grid_h / 2;
    body += Text(x, cy, map.row_label,
                 "class=\"row-label\" text-anchor=\"middle\" font-size=\"" + Num(kLabelFont) +
                     "\" transform=\"rotate(-90 " + Px(x) + " " + Px(cy) + ")\"");
  }
  // Column labels: start at the column centre just above the grid, rotated -45° (up and right).
  double right_extent = grid_right;
  for (size_t j = 0; j < nc; ++j) {
    const double x = grid_left + cw * (static_cast<double>(j) + 0.5) - kFont * 0.25;
    const double yy = grid_top - 6;
    right_extent = std::max(right_extent, x + (TextWidth(map.cols[j], kFont) + kFont) * kSin45);
    body += Text(x, yy, map.cols[j],
                 "class=\"col-name\" font-size=\"" + Num(kFont) + "\" transform=\"rotate(-45 " +
                     Px(x) + " " + Px(yy) + ")\"");
  }
  for (size_t i = 0; i < nr; ++i) {
    body += Text(grid_left - 6, grid_top + ch * (static_cast<double>(i) + 0.5) + kFont * 0.35,
                 map.rows[i],
                 "class=\"row-name\" text-anchor=\"end\" font-size=\"" + Num(kFont) + "\"");
  }

  // Cells, then their text.
  bool any_na = false;
  std::string texts;
  for (size_t i = 0; i < nr; ++i) {
    for (size_t j = 0; j < nc; ++j) {
      const size_t k = i * nc + j;
      const double v = k < map.values.size() ? map.values[k] : std::nan("");
      const bool na = !std::isfinite(v);
      any_na |= na;
      const double x = grid_left + cw * static_cast<double>(j);
      const double yy = grid_top + ch * static_cast<double>(i);
      const Rgb c = na ? Rgb{0.9, 0.9, 0.9} : Viridis(scale_t(v));
      const std::string value = na ? "n/a" : Num(v);
      body += "<rect class=\"cell\" data-row=\"" + std::to_string(i) + "\" data-col=\"" +
              std::to_string(j) + "\" data-value=\"" + value + "\" x=\"" + Px(x) + "\" y=\"" +
              Px(yy) + "\" width=\"" + Px(cw) + "\" height=\"" + Px(ch) + "\" fill=\"" +
              (na ? "url(#" + hatch_id + ")" : Hex(c)) +
              "\" stroke=\"#ffffff\" stroke-width=\"1\"><title>" +
              XmlEscape(map.rows[i] + " / " + map.cols[j] + ": " + value) + "</title></rect>\n";
      std::string text = k < map.cell_text.size() ? map.cell_text[k] : "";
      if (text.empty() && na) text = "n/a";
      if (text.empty()) continue;
      const std::vector<std::string> lines = SplitLines(text);
      const double n = static_cast<double>(lines.size());
      const double fs = std::clamp(0.8 * ch / n, 6.0, kFont), lh = fs * 1.15;
      const double cx = x + cw / 2, cy = yy + ch / 2;
      texts += "<text class=\"cell-text\" text-anchor=\"middle\" font-size=\"" + Num(fs, 3) +
               "\" fill=\"" + (na ? "#555555" : TextColourOn(c)) + "\">";
      for (size_t l = 0; l < lines.size(); ++l) {
        const double by = cy + (static_cast<double>(l) - (n - 1) / 2) * lh + fs * 0.35;
        texts +=
            "<tspan x=\"" + Px(cx) + "\" y=\"" + Px(by) + "\">" + XmlEscape(lines[l]) + "</tspan>";
      }
      texts += "</text>\n";
    }
  }
  body += texts;

  // Colour bar with ticks, to the right of the grid.
  const double bar_x = grid_right + 24, bar_w = 16, bar_top = grid_top;
  const double bar_h = std::max(grid_h, 160.0);
  body += Rect(
      bar_x, bar_top, bar_w, bar_h,
      "class=\"colour-bar\" fill=\"url(#" + grad_id + ")\" stroke=\"#444444\" stroke-width=\"1\"");
  const std::vector<double> ticks =
      AutoTicks(lo, hi, log, std::max(2, static_cast<int>(bar_h / 40)));
  double tick_w = 0, last_top = 1e9;
  for (double t : ticks) {
    const double ty = bar_top + bar_h * (1 - scale_t(t));
    body += Line(bar_x + bar_w, ty, bar_x + bar_w + 4, ty, "stroke=\"#444444\"");
    if (ty + kFont * 0.5 > last_top - 2) continue;
    last_top = ty - kFont * 0.5;
    const std::string label = FormatTick(t);
    tick_w = std::max(tick_w, TextWidth(label, kFont));
    body += Text(bar_x + bar_w + 7, ty + kFont * 0.35, label,
                 "class=\"cbar-tick\" data-value=\"" + Num(t) + "\" font-size=\"" + Num(kFont) +
                     "\" fill=\"#333333\"");
  }
  double right_edge = bar_x + bar_w + 7 + tick_w;
  if (!map.value_label.empty()) {
    const double x = right_edge + 8 + kLabelFont, cy = bar_top + bar_h / 2;
    body += Text(x, cy, map.value_label,
                 "class=\"value-label\" text-anchor=\"middle\" font-size=\"" + Num(kLabelFont) +
                     "\" transform=\"rotate(-90 " + Px(x) + " " + Px(cy) + ")\"");
    right_edge = x + 4;
  }
  double bottom_edge = std::max(grid_top + grid_h, bar_top + bar_h);
  if (any_na) {
    const double sy = bar_top + bar_h + 10;
    body += Rect(bar_x, sy, bar_w, 12,
                 "fill=\"url(#" + hatch_id + ")\" stroke=\"#444444\" stroke-width=\"1\"");
    body += Text(bar_x + bar_w + 7, sy + 10, "n/a", "font-size=\"" + Num(kFont) + "\"");
    bottom_edge = std::max(bottom_edge, sy + 12);
    right_edge = std::max(right_edge, bar_x + bar_w + 7 + TextWidth("n/a", kFont));
  }
  const double total_w = std::max({right_edge, right_extent, 10 + TextWidth(map.title, kTitleFont),
                                   10 + TextWidth(map.col_label, kLabelFont)}) +
                         12;
  return SvgOpen(total_w, bottom_edge + 12, map.title) + body + "</svg>\n";
}

}  // namespace matfit::eval
