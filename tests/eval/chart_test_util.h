// Shared helpers of the chart tests: an XML well-formedness checker, SVG attribute parsing,
// demo charts, temp files.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include <unistd.h>

#include "eval/chart.h"

namespace matfit::eval::chart_testing {

inline constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
inline constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------------------------
// A tiny XML well-formedness checker: XML declaration and comments are skipped; otherwise every
// start tag must be closed in order, there must be exactly one root element, attribute values must
// be quoted, attribute names unique per element, and '<' / '&' may only appear as markup or as
// the predefined / numeric entities. Returns an empty string when well formed, else the problem.

inline bool IsNameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':' ||
         c == '.';
}

// Checks an entity reference starting at s[i] == '&'; advances i past it.
inline bool CheckEntity(const std::string& s, size_t& i) {
  static const std::vector<std::string> kNamed = {"&amp;", "&lt;", "&gt;", "&quot;", "&apos;"};
  for (const std::string& e : kNamed) {
    if (s.compare(i, e.size(), e) == 0) {
      i += e.size();
      return true;
    }
  }
  if (s.compare(i, 2, "&#") == 0) {
    size_t j = i + 2;
    while (j < s.size() && std::isxdigit(static_cast<unsigned char>(s[j]))) ++j;
    if (j < s.size() && s[j] == ';' && j > i + 2) {
      i = j + 1;
      return true;
    }
  }
  return false;
}

inline std::string CheckXml(const std::string& s) {
  std::vector<std::string> stack;
  bool root_seen = false;
  size_t i = 0;
  auto name_at = [&](size_t& k) {
    const size_t start = k;
    while (k < s.size() && IsNameChar(s[k])) ++k;
    return s.substr(start, k - start);
  };
  auto skip_ws = [&](size_t& k) {
    while (k < s.size() && std::isspace(static_cast<unsigned char>(s[k]))) ++k;
  };
  while (i < s.size()) {
    const char c = s[i];
    if (c == '&') {
      if (!CheckEntity(s, i)) return "bad entity at " + std::to_string(i);
      continue;
    }
    if (c != '<') {
      if (stack.empty() && !std::isspace(static_cast<unsigned char>(c))) {
        return "text outside the root at " + std::to_string(i);
      }
      ++i;
      continue;
    }
    if (s.compare(i, 2, "<?") == 0) {
      if (root_seen) return "processing instruction after root";
      const size_t end = s.find("?>", i);
      if (end == std::string::npos) return "unterminated <?";
      i = end + 2;
      continue;
    }
    if (s.compare(i, 4, "<!--") == 0) {
      const size_t end = s.find("-->", i);
      if (end == std::string::npos) return "unterminated comment";
      i = end + 3;
      continue;
    }
    if (s.compare(i, 2, "</") == 0) {
      i += 2;
      const std::string name = name_at(i);
      skip_ws(i);
      if (i >= s.size() || s[i] != '>') return "bad end tag </" + name;
      ++i;
      if (stack.empty() || stack.back() != name) {
        return "end tag </" + name + "> does not match <" + (stack.empty() ? "" : stack.back()) +
               ">";
      }
      stack.pop_back();
      continue;
    }
    ++i;  // start tag
    const std::string name = name_at(i);
    if (name.empty()) return "empty tag name at " + std::to_string(i);
    if (stack.empty() && root_seen) return "second root element <" + name + ">";
    root_seen = true;
    std::set<std::string> attrs;
    while (true) {
      const size_t before = i;
      skip_ws(i);
      if (i >= s.size()) return "unterminated tag <" + name;
      if (s.compare(i, 2, "/>") == 0) {
        i += 2;
        break;
      }
      if (s[i] == '>') {
        ++i;
        stack.push_back(name);
        break;
      }
      if (i == before) return "no space before attribute in <" + name;
      const std::string attr = name_at(i);
      if (attr.empty()) return "bad attribute in <" + name + "> at " + std::to_string(i);
      if (!attrs.insert(attr).second) return "duplicate attribute " + attr + " in <" + name;
      if (i >= s.size() || s[i] != '=') return "attribute " + attr + " without '='";
      ++i;
      if (i >= s.size() || (s[i] != '"' && s[i] != '\'')) return "unquoted attribute " + attr;
      const char quote = s[i++];
      while (i < s.size() && s[i] != quote) {
        if (s[i] == '<') return "'<' in attribute " + attr;
        if (s[i] == '&') {
          if (!CheckEntity(s, i)) return "bad entity in attribute " + attr;
        } else {
          ++i;
        }
      }
      if (i >= s.size()) return "unterminated attribute " + attr;
      ++i;
    }
  }
  if (!stack.empty()) return "unclosed <" + stack.back() + ">";
  if (!root_seen) return "no root element";
  return "";
}

inline std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

inline size_t Count(const std::string& haystack, const std::string& needle) {
  size_t n = 0;
  for (size_t p = haystack.find(needle); p != std::string::npos; p = haystack.find(needle, p + 1)) {
    ++n;
  }
  return n;
}

struct Tick {
  double pos;
  std::string label;
};

// Tick labels of class `cls` ("xtick" / "ytick"): x or y position and text, in document order.
inline std::vector<Tick> ParseTicks(const std::string& svg, const std::string& cls, bool use_x) {
  const std::regex re("<text x=\"([-0-9.]+)\" y=\"([-0-9.]+)\" class=\"" + cls +
                      "\"[^>]*>([^<]*)</text>");
  std::vector<Tick> ticks;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it) {
    ticks.push_back({std::stod((*it)[use_x ? 1 : 2].str()), (*it)[3].str()});
  }
  return ticks;
}

struct RectAttr {
  double x, y, w, h;
};

// First <rect> with the given class.
inline bool ParseRect(const std::string& svg, const std::string& cls, RectAttr* r) {
  const std::regex re(
      "<rect x=\"([-0-9.]+)\" y=\"([-0-9.]+)\" width=\"([-0-9.]+)\" height=\"([-0-9.]+)\" "
      "class=\"" +
      cls + "\"");
  std::smatch m;
  if (!std::regex_search(svg, m, re)) return false;
  *r = {std::stod(m[1].str()), std::stod(m[2].str()), std::stod(m[3].str()), std::stod(m[4].str())};
  return true;
}

inline double SvgWidth(const std::string& svg) {
  std::smatch m;
  if (!std::regex_search(svg, m, std::regex("<svg [^>]*width=\"([0-9.]+)\""))) return -1;
  return std::stod(m[1].str());
}

inline XYChart DemoChart() {
  XYChart c;
  c.title = "Fit quality vs time";
  c.x_label = "fit time (s)";
  c.y_label = "error (dE)";
  c.log_x = true;
  Series a;
  a.label = "method A";
  a.x = {0.02, 0.2, 2, 20};
  a.y = {3, 2, 1.2, 1.1};
  a.point_labels = {"a1", "a2", "a3", "a4"};
  a.line = true;
  Series b;
  b.label = "method B";
  b.x = {0.05, 0.5, 5};
  b.y = {2.5, 1.0, 0.9};
  c.series = {a, b};
  std::vector<double> xs, ys;
  for (const Series& s : c.series) {
    xs.insert(xs.end(), s.x.begin(), s.x.end());
    ys.insert(ys.end(), s.y.begin(), s.y.end());
  }
  c.pareto = ParetoFront(xs, ys);
  return c;
}

inline HeatMap DemoMap() {
  HeatMap m;
  m.title = "Mean error per material";
  m.row_label = "method";
  m.col_label = "material";
  m.value_label = "error (dE)";
  m.rows = {"fast", "accurate", "hybrid"};
  m.cols = {"brushed aluminium", "velvet", "car paint", "glass"};
  m.values = {0.1, 0.5, 0.9, kNaN, 0.2, 0.3, 0.4, 0.6, 0.0, 1.0, 0.7, 0.8};
  for (double v : m.values) {
    m.cell_text.push_back(std::isnan(v) ? "" : std::to_string(static_cast<int>(v * 10)) + "°\n2 %");
  }
  return m;
}

inline std::filesystem::path TempDir() {
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / ("chart_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

inline void WriteFile(const std::filesystem::path& p, const std::string& s) {
  std::ofstream(p, std::ios::binary) << s;
}

// ---------------------------------------------------------------------------------------------

}  // namespace matfit::eval::chart_testing
