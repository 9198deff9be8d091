// Small, dependency-free SVG charts for evaluation reports: scatter/line charts with optional
// log axes and a Pareto front, and annotated heat maps with a colour bar.
//
// All functions are pure (no I/O); they return complete standalone SVG 1.1 documents. Numbers are
// printed with std::to_chars, so the output does not depend on the C/C++ locale.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace matfit::eval {

struct Series {
  std::string label;                      // legend entry (empty: no legend entry)
  std::vector<double> x, y;               // same length (extra elements of the longer are ignored)
  std::vector<std::string> point_labels;  // empty or same length: text drawn next to each point
  bool line = false;                      // connect points in order (else markers only)
  bool markers = true;
};

struct XYChart {
  std::string title, x_label, y_label;  // axis labels include units, e.g. "fit time (s)"
  bool log_x = false, log_y = false;
  std::vector<Series> series;
  // Optional Pareto front: indices into a flattened list of all points of all series in order
  // (series 0 points first, then series 1 ...), drawn as a stepped dashed polyline plus ringed
  // markers, with a legend entry "Pareto front". Invalid indices and skipped points are ignored.
  std::vector<size_t> pareto;
  // Empty: automatic (nice ticks; decades on log axes). Otherwise these x ticks are drawn and the
  // x range is widened to include them (non-finite, and on a log axis non-positive, are ignored).
  std::vector<double> x_ticks;
  int width = 800, height = 520;  // size without the legend; the legend widens the SVG
};

// Draws a scatter/line chart: title, framed plot area with grid lines and tick labels, axis
// labels, one colour (and, after 10 series, one more marker shape) per series, point labels, the
// optional Pareto front, and a legend to the right of the plot. Non-finite points (and on log axes
// non-positive ones) are skipped; a chart without drawable points shows a "no data" note.
std::string XYChartSvg(const XYChart& chart);

struct HeatMap {
  std::string title, row_label, col_label, value_label;  // value_label: colour-bar title with units
  std::vector<std::string> rows, cols;
  // rows.size() * cols.size(), row-major; NaN (or any non-finite, or missing) = no value, drawn
  // hatched grey with "n/a". With log_scale, values <= 0 clamp to vmin.
  std::vector<double> values;
  std::vector<std::string> cell_text;  // empty or same size: text in each cell (e.g. "0.3°\n2 %")
  double vmin = 0, vmax = 1;           // colour scale range (values clamp)
  // Log colour scale (vmin > 0; otherwise the smallest positive value, or vmax / 1000, is used).
  bool log_scale = false;
  int cell_width = 70, cell_height = 26;
};

// Draws a heat map: title, row labels on the left, column labels rotated -45° above the grid,
// one <rect class="cell" data-row data-col data-value> per cell coloured on a viridis-like scale,
// cell text in black or white for contrast, and a colour bar with tick labels on the right.
std::string HeatMapSvg(const HeatMap& map);

// Indices of the points on the lower-left Pareto front when minimising both x and y
// (a point is on the front when no other point is <= in both and < in one), sorted by x
// (ties by index). Exact duplicates on the front are all kept. Points with a non-finite coordinate
// are ignored; only the first min(x.size(), y.size()) points are considered.
std::vector<size_t> ParetoFront(const std::vector<double>& x, const std::vector<double>& y);

// Escapes &, <, >, " and ' for SVG text/attributes. Control characters that XML 1.0 forbids
// (below 0x20 except tab, newline and carriage return) are dropped.
std::string XmlEscape(const std::string& s);

// --- Helpers used by the charts, exposed for tests. ---

// Maps a data value to a pixel coordinate: with f = identity (linear) or log10 (log),
//   pixel = p0 + (f(v) - f(lo)) / (f(hi) - f(lo)) * (p1 - p0).
// p1 < p0 is allowed (y axes grow upwards). Requires lo < hi (and lo > 0 when log).
struct AxisMap {
  double lo = 0, hi = 1;  // data range
  double p0 = 0, p1 = 1;  // pixel range
  bool log = false;
  double operator()(double v) const;
};

// Tick values for the data range [lo, hi]: "nice" 1/2/5 x 10^k steps aiming at about
// `target` ticks on linear axes; decades (every k-th decade when there are many; plus 2 and 5
// times a decade when only two decades are visible) on log axes. Only ticks inside [lo, hi].
std::vector<double> AutoTicks(double lo, double hi, bool log, int target);

// Tick label: up to 6 significant digits, plain notation between 1e-3 and 1e6 (0.001, 0.01, 10),
// exponent notation outside it (1e-4, 2.5e7).
std::string FormatTick(double v);

}  // namespace matfit::eval
