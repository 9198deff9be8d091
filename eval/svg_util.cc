#include "eval/svg_util.h"
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

namespace matfit::eval::svg {

using ::matfit::eval::XmlEscape;

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
std::string Num(double v, int digits) {
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

// Sequential scale: viridis sampled at 6 stops, interpolated linearly in sRGB.

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

}  // namespace matfit::eval::svg
