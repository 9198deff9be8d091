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

namespace matfit::eval {
namespace {

// ---------------------------------------------------------------------------------------------
// Number formatting (std::to_chars: locale independent, never prints nan/inf).

std::string ToChars(double v, std::chars_format fmt, int precision) {
  if (!std::isfinite(v)) v = 0;
  char buf[400];
  const auto r = std::to_chars(buf, buf + sizeof buf, v, fmt, precision);
  if (r.ec != std::errc()) return "0";
  return std::string(buf, r.ptr);
}

// Drops exponent padding and '+': "1e-04" -> "1e-4", "2.5e+06" -> "2.5e6".
std::string TidyExponent(const std::string& s) {
  const size_t e = s.find('e');
  if (e == std::string::npos) return s;
  std::string out = s.substr(0, e) + "e";
  size_t i = e + 1;
  if (i < s.size() && (s[i] == '-' || s[i] == '+')) {
    if (s[i] == '-') out += '-';
    ++i;
  }
  while (i + 1 < s.size() && s[i] == '0') ++i;
  return out + s.substr(i);
}

// Trims trailing zeros of a fixed or scientific mantissa: "1.500" -> "1.5", "2.000e-04" -> "2e-04".
std::string TrimZeros(const std::string& s) {
  const size_t e = std::min(s.find('e'), s.size());
  std::string mant = s.substr(0, e);
  if (mant.find('.') != std::string::npos) {
    while (!mant.empty() && mant.back() == '0') mant.pop_back();
    if (!mant.empty() && mant.back() == '.') mant.pop_back();
  }
  if (mant == "-0") mant = "0";
  return mant + s.substr(e);
}

// A value with `digits` significant digits, like printf("%.6g") in the C locale.
std::string Num(double v, int digits = 6) {
  return TidyExponent(ToChars(v, std::chars_format::general, digits));
}

// A pixel coordinate with at most two decimals ("%.2f" without trailing zeros).
std::string Px(double v) {
  if (!std::isfinite(v)) v = 0;
  v = std::clamp(v, -1e6, 1e6);
  return TrimZeros(ToChars(v, std::chars_format::fixed, 2));
}

// ---------------------------------------------------------------------------------------------
// Text metrics (estimates: no font access). Average sans-serif glyph ~0.6 em; counts UTF-8 code
// points, not bytes.

double TextWidth(std::string_view s, double font_size) {
  size_t n = 0;
  for (unsigned char c : s) n += (c & 0xC0) != 0x80;
  return static_cast<double>(n) * 0.6 * font_size;
}

// Splits on '\n'.
std::vector<std::string> SplitLines(const std::string& s) {
  std::vector<std::string> lines(1);
  for (char c : s) {
    if (c == '\n') {
      lines.emplace_back();
    } else {
      lines.back() += c;
    }
  }
  return lines;
}

// ---------------------------------------------------------------------------------------------
// Colours.

struct Rgb {
  double r, g, b;  // sRGB in [0, 1]
};

std::string Hex(const Rgb& c) {
  static const char kDigits[] = "0123456789abcdef";
  std::string s = "#";
  for (double v : {c.r, c.g, c.b}) {
    const int i = static_cast<int>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
    s += kDigits[i >> 4];
    s += kDigits[i & 15];
  }
  return s;
}

Rgb FromHex(uint32_t h) {
  return {((h >> 16) & 255) / 255.0, ((h >> 8) & 255) / 255.0, (h & 255) / 255.0};
}

// WCAG relative luminance (linearised sRGB).
double Luminance(const Rgb& c) {
  auto lin = [](double v) { return v <= 0.04045 ? v / 12.92 : std::pow((v + 0.055) / 1.055, 2.4); };
  return 0.2126 * lin(c.r) + 0.7152 * lin(c.g) + 0.0722 * lin(c.b);
}

// Black or white, whichever has the higher contrast ratio against `bg`.
const char* TextColourOn(const Rgb& bg) {
  const double l = Luminance(bg);
  return (l + 0.05) / 0.05 >= 1.05 / (l + 0.05) ? "#000000" : "#ffffff";
}

// Qualitative palette (matplotlib "tab10").
constexpr std::array<uint32_t, 10> kPalette = {0x1f77b4, 0xff7f0e, 0x2ca02c, 0xd62728, 0x9467bd,
                                               0x8c564b, 0xe377c2, 0x7f7f7f, 0xbcbd22, 0x17becf};

// Sequential scale: viridis sampled at 6 stops, interpolated linearly in sRGB.
constexpr std::array<uint32_t, 6> kViridis = {0x440154, 0x414487, 0x2a788e,
                                              0x22a884, 0x7ad151, 0xfde725};

Rgb Viridis(double t) {
  t = std::clamp(std::isfinite(t) ? t : 0.0, 0.0, 1.0);
  const double s = t * (kViridis.size() - 1);
  const size_t i = std::min(static_cast<size_t>(s), kViridis.size() - 2);
  const double f = s - static_cast<double>(i);
  const Rgb a = FromHex(kViridis[i]), b = FromHex(kViridis[i + 1]);
  return {a.r + f * (b.r - a.r), a.g + f * (b.g - a.g), a.b + f * (b.b - a.b)};
}

// ---------------------------------------------------------------------------------------------
// SVG document pieces.

std::string SvgOpen(double width, double height, const std::string& title) {
  const std::string w = Px(std::ceil(width)), h = Px(std::ceil(height));
  std::string s = "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n";
  s += "<svg xmlns=\"http://www.w3.org/2000/svg\" version=\"1.1\" width=\"" + w + "\" height=\"" +
       h + "\" viewBox=\"0 0 " + w + " " + h + "\" font-family=\"sans-serif\" font-size=\"12\">\n";
  if (!title.empty()) s += "<title>" + XmlEscape(title) + "</title>\n";
  s += "<rect x=\"0\" y=\"0\" width=\"" + w + "\" height=\"" + h + "\" fill=\"#ffffff\"/>\n";
  return s;
}

// <text> element; `extra` holds additional attributes (already escaped).
std::string Text(double x, double y, const std::string& text, const std::string& extra) {
  return "<text x=\"" + Px(x) + "\" y=\"" + Px(y) + "\"" + (extra.empty() ? "" : " " + extra) +
         ">" + XmlEscape(text) + "</text>\n";
}

std::string Line(double x1, double y1, double x2, double y2, const std::string& extra) {
  return "<line x1=\"" + Px(x1) + "\" y1=\"" + Px(y1) + "\" x2=\"" + Px(x2) + "\" y2=\"" + Px(y2) +
         "\" " + extra + "/>\n";
}

std::string Rect(double x, double y, double w, double h, const std::string& extra) {
  return "<rect x=\"" + Px(x) + "\" y=\"" + Px(y) + "\" width=\"" + Px(w) + "\" height=\"" + Px(h) +
         "\" " + extra + "/>\n";
}

// Marker shape `shape` (0 circle, 1 square, 2 triangle up, 3 diamond, 4 triangle down) centred
// on (x, y); fill/stroke come from the enclosing group.
constexpr int kNumShapes = 5;

std::string Marker(int shape, double x, double y) {
  auto pt = [](double px, double py) { return Px(px) + "," + Px(py); };
  switch (shape % kNumShapes) {
    case 0: return "<circle cx=\"" + Px(x) + "\" cy=\"" + Px(y) + "\" r=\"4\"/>\n";
    case 1: return Rect(x - 3.6, y - 3.6, 7.2, 7.2, "");
    case 2:
      return "<path d=\"M" + pt(x, y - 5) + " L" + pt(x + 4.5, y + 3.2) + " L" +
             pt(x - 4.5, y + 3.2) + " Z\"/>\n";
    case 3:
      return "<path d=\"M" + pt(x, y - 5) + " L" + pt(x + 5, y) + " L" + pt(x, y + 5) + " L" +
             pt(x - 5, y) + " Z\"/>\n";
    default:
      return "<path d=\"M" + pt(x, y + 5) + " L" + pt(x + 4.5, y - 3.2) + " L" +
             pt(x - 4.5, y - 3.2) + " Z\"/>\n";
  }
}

// ---------------------------------------------------------------------------------------------
// Axis ranges and ticks.

bool Usable(double v, bool log) { return std::isfinite(v) && (!log || v > 0); }

// Turns the range of the data [lo, hi] into the axis range: pads by 5 % of the span (in log10
// space on log axes) so markers do not sit on the frame; constant data gets a fixed pad (±10 %,
// or ±1 around 0; half a decade on log axes) so the mapping never divides by zero. Log axes are
// widened to the enclosing decades when fewer than two decade ticks would be visible.
void PadRange(double& lo, double& hi, bool log, bool have_data) {
  if (!have_data) {
    lo = log ? 1 : 0;
    hi = log ? 10 : 1;
    return;
  }
  if (log) {
    double a = std::log10(lo), b = std::log10(hi);
    const double span = b - a;
    if (span < 1e-9) {
      a -= 0.5;
      b += 0.5;
    } else {
      a -= 0.05 * span;
      b += 0.05 * span;
    }
    if (std::floor(b + 1e-9) - std::ceil(a - 1e-9) < 1) {
      a = std::floor(a);
      b = std::max(std::ceil(b), a + 1);
    }
    lo = std::pow(10.0, a);
    hi = std::pow(10.0, b);
    return;
  }
  const double span = hi - lo;
  const double mag = std::max({1e-300, std::fabs(lo), std::fabs(hi)});
  if (!(span > 1e-12 * mag)) {
    const double pad = lo == 0 ? 1.0 : 0.1 * std::fabs(lo);
    lo -= pad;
    hi += pad;
  } else {
    lo -= 0.05 * span;
    hi += 0.05 * span;
  }
}

std::vector<double> LinearTicks(double lo, double hi, int target) {
  std::vector<double> ticks;
  const double span = hi - lo;
  if (!(span > 0) || !std::isfinite(span)) return ticks;
  const double raw = span / std::max(target, 1);
  const double mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double n = raw / mag;
  const double step = (n < 1.5 ? 1 : n < 3 ? 2 : n < 7 ? 5 : 10) * mag;
  const double k0 = std::ceil(lo / step - 1e-9), k1 = std::floor(hi / step + 1e-9);
  for (double k = k0; k <= k1 && ticks.size() < 1000; k += 1) {
    const double v = k * step;
    ticks.push_back(std::fabs(v) < step * 1e-9 ? 0.0 : v);
  }
  return ticks;
}

// Decade exponent range [e0, e1] inside [lo, hi] and the labelling stride.
struct Decades {
  int e0, e1, stride;
};

Decades LogDecades(double lo, double hi, int target) {
  const int e0 = static_cast<int>(std::ceil(std::log10(lo) - 1e-9));
  const int e1 = static_cast<int>(std::floor(std::log10(hi) + 1e-9));
  const int n = e1 - e0 + 1;
  const int t = std::max(target, 2);
  return {e0, e1, std::max(1, (n + t - 1) / t)};
}

// Grid-only ticks: 2..9 x 10^e on log axes (or the unlabelled decades when decades are skipped).
std::vector<double> MinorTicks(double lo, double hi, bool log, int target) {
  std::vector<double> minor;
  if (!log) return minor;
  const Decades d = LogDecades(lo, hi, target);
  if (d.stride > 1) {
    for (int e = d.e0; e <= d.e1; ++e) {
      if (e % d.stride != 0) minor.push_back(std::pow(10.0, e));
    }
    return minor;
  }
  for (int e = d.e0 - 1; e <= d.e1; ++e) {
    for (int m = 2; m <= 9; ++m) {
      const double v = m * std::pow(10.0, e);
      if (v >= lo && v <= hi) minor.push_back(v);
    }
  }
  return minor;
}

// Keeps the ticks inside [lo, hi] (with a tiny tolerance), sorted and unique.
std::vector<double> TicksInRange(std::vector<double> ticks, double lo, double hi) {
  const double tol = (hi - lo) * 1e-9;
  std::vector<double> out;
  for (double t : ticks) {
    if (std::isfinite(t) && t >= lo - tol && t <= hi + tol) out.push_back(t);
  }
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Public helpers.

double AxisMap::operator()(double v) const {
  const double a = log ? std::log10(lo) : lo;
  const double b = log ? std::log10(hi) : hi;
  const double f = log ? std::log10(v) : v;
  return p0 + (f - a) / (b - a) * (p1 - p0);
}

std::vector<double> AutoTicks(double lo, double hi, bool log, int target) {
  if (!(lo < hi) || !std::isfinite(lo) || !std::isfinite(hi)) return {};
  if (!log) return LinearTicks(lo, hi, target);
  if (!(lo > 0)) return {};
  const Decades d = LogDecades(lo, hi, target);
  std::vector<double> ticks;
  if (d.e1 < d.e0) return LinearTicks(lo, hi, target);  // range inside one decade
  for (int e = d.e0; e <= d.e1; ++e) {
    if (e % d.stride == 0) ticks.push_back(std::pow(10.0, e));
  }
  if (d.e1 - d.e0 <= 1) {  // at most two decades visible: add 2x and 5x
    for (int e = d.e0 - 1; e <= d.e1; ++e) {
      ticks.push_back(2 * std::pow(10.0, e));
      ticks.push_back(5 * std::pow(10.0, e));
    }
  }
  return TicksInRange(ticks, lo, hi);
}

std::string FormatTick(double v) {
  if (!std::isfinite(v)) return "";
  if (v == 0) return "0";
  const double a = std::fabs(v);
  if (a < 1e-3 * (1 - 1e-12) || a >= 1e6) {
    return TidyExponent(TrimZeros(ToChars(v, std::chars_format::scientific, 5)));
  }
  return Num(v, 6);
}

std::string XmlEscape(const std::string& s) {
  std::string out;
  out.reserve(s.size());
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&apos;"; break;
      default:
        if (static_cast<unsigned char>(c) < 0x20 && c != '\t' && c != '\n' && c != '\r') break;
        out += c;
    }
  }
  return out;
}

std::vector<size_t> ParetoFront(const std::vector<double>& x, const std::vector<double>& y) {
  const size_t n = std::min(x.size(), y.size());
  std::vector<size_t> order;
  for (size_t i = 0; i < n; ++i) {
    if (std::isfinite(x[i]) && std::isfinite(y[i])) order.push_back(i);
  }
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (x[a] != x[b]) return x[a] < x[b];
    if (y[a] != y[b]) return y[a] < y[b];
    return a < b;
  });
  // Sweep groups of equal x in increasing x. A point is dominated by a point of its own group with
  // a smaller y, or by an earlier group (smaller x) whose best y is <= its y.
  std::vector<size_t> front;
  double best_y = std::numeric_limits<double>::infinity();  // min y over strictly smaller x
  for (size_t g = 0; g < order.size();) {
    size_t end = g;
    while (end < order.size() && x[order[end]] == x[order[g]]) ++end;
    const double group_min = y[order[g]];  // sorted by y within the group
    if (group_min < best_y) {
      for (size_t k = g; k < end && y[order[k]] == group_min; ++k) front.push_back(order[k]);
    }
    best_y = std::min(best_y, group_min);
    g = end;
  }
  return front;
}

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
