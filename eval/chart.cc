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

}  // namespace matfit::eval
