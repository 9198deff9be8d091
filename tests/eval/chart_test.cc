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

namespace matfit::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// ---------------------------------------------------------------------------------------------
// A tiny XML well-formedness checker: XML declaration and comments are skipped; otherwise every
// start tag must be closed in order, there must be exactly one root element, attribute values must
// be quoted, attribute names unique per element, and '<' / '&' may only appear as markup or as
// the predefined / numeric entities. Returns an empty string when well formed, else the problem.

bool IsNameChar(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_' || c == ':' ||
         c == '.';
}

// Checks an entity reference starting at s[i] == '&'; advances i past it.
bool CheckEntity(const std::string& s, size_t& i) {
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

std::string CheckXml(const std::string& s) {
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

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

size_t Count(const std::string& haystack, const std::string& needle) {
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
std::vector<Tick> ParseTicks(const std::string& svg, const std::string& cls, bool use_x) {
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
bool ParseRect(const std::string& svg, const std::string& cls, RectAttr* r) {
  const std::regex re(
      "<rect x=\"([-0-9.]+)\" y=\"([-0-9.]+)\" width=\"([-0-9.]+)\" height=\"([-0-9.]+)\" "
      "class=\"" +
      cls + "\"");
  std::smatch m;
  if (!std::regex_search(svg, m, re)) return false;
  *r = {std::stod(m[1].str()), std::stod(m[2].str()), std::stod(m[3].str()), std::stod(m[4].str())};
  return true;
}

double SvgWidth(const std::string& svg) {
  std::smatch m;
  if (!std::regex_search(svg, m, std::regex("<svg [^>]*width=\"([0-9.]+)\""))) return -1;
  return std::stod(m[1].str());
}

XYChart DemoChart() {
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

HeatMap DemoMap() {
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

std::filesystem::path TempDir() {
  const std::filesystem::path dir =
      std::filesystem::path(::testing::TempDir()) / ("chart_test_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir;
}

void WriteFile(const std::filesystem::path& p, const std::string& s) {
  std::ofstream(p, std::ios::binary) << s;
}

// ---------------------------------------------------------------------------------------------

TEST(XmlChecker, AcceptsGoodAndRejectsBadDocuments) {
  EXPECT_EQ(CheckXml("<?xml version=\"1.0\"?>\n<a x=\"1\"><b/><c y='2'>t &amp; u</c></a>\n"), "");
  EXPECT_NE(CheckXml("<a><b></a></b>"), "");
  EXPECT_NE(CheckXml("<a x=1/>"), "");
  EXPECT_NE(CheckXml("<a>x & y</a>"), "");
  EXPECT_NE(CheckXml("<a/><b/>"), "");
  EXPECT_NE(CheckXml("<a x=\"1\" x=\"2\"/>"), "");
  EXPECT_NE(CheckXml("<a>"), "");
  EXPECT_NE(CheckXml("<a t=\"<\"/>"), "");
}

TEST(ParetoFront, KnownSet) {
  //            0  1  2  3  4  5
  const std::vector<double> x = {1, 2, 3, 4, 2.5, 5};
  const std::vector<double> y = {5, 3, 4, 1, 2, 0.5};
  // 2 is dominated by 1 (2<=3, 3<=4); all others are on the front.
  EXPECT_EQ(ParetoFront(x, y), (std::vector<size_t>{0, 1, 4, 3, 5}));
}

TEST(ParetoFront, TiesAndDuplicates) {
  // Same x, larger y: dominated. Same y, larger x: dominated. Exact duplicates: both kept.
  const std::vector<double> x = {1, 1, 2, 3, 2, 0.5};
  const std::vector<double> y = {2, 3, 1, 1, 1, 9};
  EXPECT_EQ(ParetoFront(x, y), (std::vector<size_t>{5, 0, 2, 4}));
  // Duplicate that is dominated by a third point: both dropped.
  EXPECT_EQ(ParetoFront({2, 2, 1}, {2, 2, 1}), (std::vector<size_t>{2}));
  // All identical.
  EXPECT_EQ(ParetoFront({1, 1, 1}, {1, 1, 1}), (std::vector<size_t>{0, 1, 2}));
}

TEST(ParetoFront, EdgeCases) {
  EXPECT_TRUE(ParetoFront({}, {}).empty());
  EXPECT_EQ(ParetoFront({3}, {4}), (std::vector<size_t>{0}));
  // NaN / inf points are ignored and never dominate.
  EXPECT_EQ(ParetoFront({kNaN, 1, -kInf, 2}, {0, 1, 0, kNaN}), (std::vector<size_t>{1}));
  // Only min(size) points considered.
  EXPECT_EQ(ParetoFront({1, 2, 0}, {1, 0}), (std::vector<size_t>{0, 1}));
}

TEST(ParetoFront, MatchesBruteForce) {
  std::vector<double> x, y;
  unsigned state = 12345;
  for (int i = 0; i < 300; ++i) {
    state = state * 1103515245u + 12345u;
    x.push_back((state >> 16) % 20);
    state = state * 1103515245u + 12345u;
    y.push_back((state >> 16) % 20);
  }
  std::vector<size_t> expected;
  for (size_t i = 0; i < x.size(); ++i) {
    bool dominated = false;
    for (size_t j = 0; j < x.size() && !dominated; ++j) {
      dominated = x[j] <= x[i] && y[j] <= y[i] && (x[j] < x[i] || y[j] < y[i]);
    }
    if (!dominated) expected.push_back(i);
  }
  std::sort(expected.begin(), expected.end(),
            [&](size_t a, size_t b) { return x[a] != x[b] ? x[a] < x[b] : a < b; });
  EXPECT_EQ(ParetoFront(x, y), expected);
}

TEST(XmlEscape, EscapesSpecialCharacters) {
  EXPECT_EQ(XmlEscape("a<b>&\"c\"'d'"), "a&lt;b&gt;&amp;&quot;c&quot;&apos;d&apos;");
  EXPECT_EQ(XmlEscape("plain 0.3° µm"), "plain 0.3° µm");
  EXPECT_EQ(XmlEscape("&amp;"), "&amp;amp;");
  EXPECT_EQ(XmlEscape(std::string("a\x01"
                                  "b\tc")),
            "ab\tc");  // forbidden control char dropped
  EXPECT_EQ(XmlEscape(""), "");
}

TEST(AxisMap, LinearAndLog) {
  const AxisMap lin{0, 10, 100, 200, false};
  EXPECT_DOUBLE_EQ(lin(0), 100);
  EXPECT_DOUBLE_EQ(lin(5), 150);
  EXPECT_DOUBLE_EQ(lin(10), 200);
  const AxisMap up{0, 10, 400, 100, false};  // y axis: larger values higher up
  EXPECT_DOUBLE_EQ(up(10), 100);
  EXPECT_DOUBLE_EQ(up(2.5), 325);
  const AxisMap lg{1, 1000, 0, 300, true};
  EXPECT_NEAR(lg(1), 0, 1e-9);
  EXPECT_NEAR(lg(10), 100, 1e-9);
  EXPECT_NEAR(lg(100), 200, 1e-9);
  EXPECT_NEAR(lg(1000), 300, 1e-9);
  EXPECT_NEAR(lg(std::sqrt(10.0)), 50, 1e-9);
}

TEST(AutoTicks, LinearNiceSteps) {
  const std::vector<double> t = AutoTicks(0, 1, false, 5);
  ASSERT_EQ(t.size(), 6u);
  for (size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(t[i], 0.2 * static_cast<double>(i), 1e-12);
  const std::vector<double> u = AutoTicks(-3.3, 17.2, false, 5);
  EXPECT_EQ(u, (std::vector<double>{0, 5, 10, 15}));
  EXPECT_TRUE(AutoTicks(1, 1, false, 5).empty());
  EXPECT_TRUE(AutoTicks(kNaN, 1, false, 5).empty());
}

TEST(AutoTicks, LogDecades) {
  EXPECT_EQ(AutoTicks(0.0005, 20, true, 8), (std::vector<double>{0.001, 0.01, 0.1, 1, 10}));
  // Two decades visible: 2x and 5x added.
  EXPECT_EQ(AutoTicks(1, 10, true, 6), (std::vector<double>{1, 2, 5, 10}));
  // Many decades: every k-th decade only.
  const std::vector<double> wide = AutoTicks(1e-12, 1e12, true, 6);
  EXPECT_LE(wide.size(), 7u);
  EXPECT_GE(wide.size(), 4u);
  for (double v : wide) EXPECT_NEAR(std::log10(v), std::round(std::log10(v)), 1e-9);
  EXPECT_TRUE(AutoTicks(0, 10, true, 6).empty());
}

TEST(FormatTick, Labels) {
  EXPECT_EQ(FormatTick(0.001), "0.001");
  EXPECT_EQ(FormatTick(0.01), "0.01");
  EXPECT_EQ(FormatTick(0.1), "0.1");
  EXPECT_EQ(FormatTick(1), "1");
  EXPECT_EQ(FormatTick(10), "10");
  EXPECT_EQ(FormatTick(1e-4), "1e-4");
  EXPECT_EQ(FormatTick(2.5e7), "2.5e7");
  EXPECT_EQ(FormatTick(0.1 + 0.2), "0.3");
  EXPECT_EQ(FormatTick(3 * 1e-5), "3e-5");
  EXPECT_EQ(FormatTick(0), "0");
  EXPECT_EQ(FormatTick(-0.5), "-0.5");
  EXPECT_EQ(FormatTick(123456), "123456");
  EXPECT_EQ(FormatTick(kNaN), "");
}

TEST(XYChartSvg, WellFormedStandaloneDocument) {
  const std::string svg = XYChartSvg(DemoChart());
  EXPECT_EQ(CheckXml(svg), "");
  EXPECT_NE(svg.find("xmlns=\"http://www.w3.org/2000/svg\""), std::string::npos);
  EXPECT_NE(svg.find("version=\"1.1\""), std::string::npos);
  EXPECT_NE(svg.find("viewBox=\"0 0 "), std::string::npos);
  EXPECT_NE(svg.find("font-family=\"sans-serif\""), std::string::npos);
  EXPECT_NE(svg.find("fill=\"#ffffff\""), std::string::npos);
  EXPECT_NE(svg.find(">Fit quality vs time</text>"), std::string::npos);
  EXPECT_NE(svg.find(">fit time (s)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">error (dE)</text>"), std::string::npos);
  EXPECT_NE(svg.find(">method A</text>"), std::string::npos);
  EXPECT_NE(svg.find(">Pareto front</text>"), std::string::npos);
  EXPECT_EQ(Count(svg, "class=\"point-label\""), 4u);
  EXPECT_EQ(svg, XYChartSvg(DemoChart()));  // deterministic
}

TEST(XYChartSvg, LegendIsRightOfPlotAndWidensSvg) {
  const XYChart c = DemoChart();
  const std::string svg = XYChartSvg(c);
  RectAttr plot{}, legend{};
  ASSERT_TRUE(ParseRect(svg, "plot-area", &plot));
  ASSERT_TRUE(ParseRect(svg, "legend", &legend));
  EXPECT_GE(legend.x, plot.x + plot.w);
  EXPECT_GT(SvgWidth(svg), c.width);
  EXPECT_LE(legend.x + legend.w, SvgWidth(svg));
  // A label-less chart has no legend and keeps its width.
  XYChart bare = c;
  bare.pareto.clear();
  for (Series& s : bare.series) s.label.clear();
  const std::string bare_svg = XYChartSvg(bare);
  EXPECT_FALSE(ParseRect(bare_svg, "legend", &legend));
  EXPECT_EQ(SvgWidth(bare_svg), c.width);
}

TEST(XYChartSvg, LogAxisDecadesEquallySpaced) {
  XYChart c;
  c.log_x = c.log_y = true;
  Series s;
  s.label = "s";
  s.x = {1, 10, 100};
  s.y = {0.001, 0.01, 0.1};
  c.series = {s};
  const std::string svg = XYChartSvg(c);
  ASSERT_EQ(CheckXml(svg), "");
  std::map<std::string, double> xs, ys;
  for (const Tick& t : ParseTicks(svg, "xtick", true)) xs[t.label] = t.pos;
  for (const Tick& t : ParseTicks(svg, "ytick", false)) ys[t.label] = t.pos;
  ASSERT_TRUE(xs.count("1") && xs.count("10") && xs.count("100")) << svg;
  EXPECT_GT(xs["10"] - xs["1"], 50);
  EXPECT_NEAR(xs["10"] - xs["1"], xs["100"] - xs["10"], 0.02);
  ASSERT_TRUE(ys.count("0.001") && ys.count("0.01") && ys.count("0.1")) << svg;
  EXPECT_LT(ys["0.01"], ys["0.001"]);  // upwards
  EXPECT_NEAR(ys["0.001"] - ys["0.01"], ys["0.01"] - ys["0.1"], 0.02);
}

TEST(XYChartSvg, TickLabelsDoNotOverlap) {
  for (bool log : {false, true}) {
    XYChart c;
    c.log_x = log;
    c.width = 300;
    Series s;
    s.x = {log ? 1e-12 : -123456.0, log ? 1e12 : 987654.0};
    s.y = {1, 2};
    c.series = {s};
    const std::vector<Tick> ticks = ParseTicks(XYChartSvg(c), "xtick", true);
    ASSERT_GE(ticks.size(), 2u) << log;
    for (size_t i = 1; i < ticks.size(); ++i) {
      const double half = 0.6 * 11 / 2;
      EXPECT_GT(ticks[i].pos - half * static_cast<double>(ticks[i].label.size()),
                ticks[i - 1].pos + half * static_cast<double>(ticks[i - 1].label.size()))
          << ticks[i - 1].label << " / " << ticks[i].label;
    }
  }
}

TEST(XYChartSvg, NonFiniteInputsNeverLeak) {
  XYChart c = DemoChart();
  c.log_y = true;
  c.title = "robustness";
  Series bad;
  bad.label = "bad";
  bad.x = {kNaN, 1, kInf, -kInf, 2, -1, 0};
  bad.y = {1, kNaN, 1, 1, -5, 3, 4};  // -5 and 0/-1 x are not drawable on log axes
  bad.point_labels = {"p", "q", "r", "s", "t", "u", "v"};
  bad.line = true;
  c.series.push_back(bad);
  c.pareto.push_back(9999);  // out of range
  c.pareto.push_back(7);     // first point of `bad`: NaN
  c.x_ticks = {kNaN, 0.1, 1, -2, kInf};
  const std::string svg = Lower(XYChartSvg(c));
  EXPECT_EQ(CheckXml(svg), "");
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.find("inf"), std::string::npos);
  EXPECT_EQ(Count(svg, "class=\"point-label\""), 4u);  // only a1..a4 are drawable
}

TEST(XYChartSvg, LinesBreakAtSkippedPoints) {
  XYChart c;
  Series s;
  s.x = {1, 2, 3, 4};
  s.y = {1, kNaN, 3, 4};
  s.line = true;
  c.series = {s};
  const std::string svg = XYChartSvg(c);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m, std::regex("class=\"series-line\" d=\"([^\"]*)\"")));
  EXPECT_EQ(Count(m[1].str(), "M"), 2u);
  EXPECT_EQ(Count(m[1].str(), "L"), 1u);
}

TEST(XYChartSvg, EmptyChartsSayNoData) {
  XYChart none;
  none.title = "nothing";
  XYChart all_nan;
  Series s;
  s.label = "s";
  s.x = {kNaN, 1};
  s.y = {1, kNaN};
  all_nan.series = {s};
  XYChart nonpositive_log;
  nonpositive_log.log_x = true;
  Series t;
  t.x = {0, -1};
  t.y = {1, 2};
  nonpositive_log.series = {t};
  for (const XYChart& c : {none, all_nan, nonpositive_log}) {
    const std::string svg = XYChartSvg(c);
    EXPECT_EQ(CheckXml(svg), "");
    EXPECT_NE(svg.find(">no data</text>"), std::string::npos);
    EXPECT_EQ(Lower(svg).find("nan"), std::string::npos);
  }
  EXPECT_EQ(XYChartSvg(DemoChart()).find(">no data<"), std::string::npos);
}

TEST(XYChartSvg, ConstantDataIsPadded) {
  for (bool log : {false, true}) {
    for (double v : {0.0, 5.0}) {
      if (log && v == 0) continue;
      XYChart c;
      c.log_x = c.log_y = log;
      Series s;
      s.x = {v, v, v};
      s.y = {v, v, v};
      c.series = {s};
      const std::string svg = XYChartSvg(c);
      EXPECT_EQ(CheckXml(svg), "");
      EXPECT_EQ(Lower(svg).find("nan"), std::string::npos);
      EXPECT_EQ(Lower(svg).find("inf"), std::string::npos);
      EXPECT_GE(ParseTicks(svg, "xtick", true).size(), 2u) << log << " " << v;
      EXPECT_GE(ParseTicks(svg, "ytick", false).size(), 2u) << log << " " << v;
    }
  }
}

TEST(XYChartSvg, ExplicitTicksWidenRange) {
  XYChart c;
  Series s;
  s.x = {2, 3};
  s.y = {1, 2};
  c.series = {s};
  c.x_ticks = {0, 2.5, 10};
  std::vector<std::string> labels;
  for (const Tick& t : ParseTicks(XYChartSvg(c), "xtick", true)) labels.push_back(t.label);
  EXPECT_EQ(labels, (std::vector<std::string>{"0", "2.5", "10"}));
}

TEST(XYChartSvg, TextIsEscaped) {
  XYChart c;
  c.title = "<script>&\"'";
  c.x_label = "a<b";
  c.y_label = "c>d";
  Series s;
  s.label = "R&D";
  s.x = {1};
  s.y = {1};
  s.point_labels = {"x\"y"};
  c.series = {s};
  const std::string svg = XYChartSvg(c);
  EXPECT_EQ(CheckXml(svg), "");
  EXPECT_EQ(svg.find("<script>"), std::string::npos);
  EXPECT_NE(svg.find("&lt;script&gt;&amp;&quot;&apos;"), std::string::npos);
  EXPECT_NE(svg.find(">a&lt;b<"), std::string::npos);
  EXPECT_NE(svg.find(">c&gt;d<"), std::string::npos);
  EXPECT_NE(svg.find(">R&amp;D<"), std::string::npos);
  EXPECT_NE(svg.find(">x&quot;y<"), std::string::npos);
}

TEST(XYChartSvg, DistinctColoursAndShapesWhenCycling) {
  XYChart c;
  for (int i = 0; i < 12; ++i) {
    Series s;
    s.label = "series ";
    s.label += std::to_string(i);
    s.x = {static_cast<double>(i)};
    s.y = {1};
    c.series.push_back(s);
  }
  const std::string svg = XYChartSvg(c);
  const std::regex re("<g class=\"series-markers\" fill=\"(#[0-9a-f]{6})\"[^>]*>\n<([a-z]+)");
  std::vector<std::pair<std::string, std::string>> styles;  // colour, element
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it) {
    styles.emplace_back((*it)[1].str(), (*it)[2].str());
  }
  ASSERT_EQ(styles.size(), 12u);
  std::set<std::string> first10;
  for (int i = 0; i < 10; ++i) first10.insert(styles[i].first);
  EXPECT_EQ(first10.size(), 10u);
  EXPECT_EQ(styles[10].first, styles[0].first);    // colours cycle ...
  EXPECT_NE(styles[10].second, styles[0].second);  // ... with another marker shape
  const std::set<std::pair<std::string, std::string>> unique(styles.begin(), styles.end());
  EXPECT_EQ(unique.size(), 12u);
}

TEST(XYChartSvg, ParetoFrontIsSteppedAndRinged) {
  XYChart c;
  Series s;
  s.label = "s";
  s.x = {1, 2, 3, 2.5};
  s.y = {3, 2, 1, 2.5};
  c.series = {s};
  c.pareto = ParetoFront(s.x, s.y);
  ASSERT_EQ(c.pareto, (std::vector<size_t>{0, 1, 2}));
  const std::string svg = XYChartSvg(c);
  std::smatch m;
  ASSERT_TRUE(std::regex_search(svg, m, std::regex("class=\"pareto-line\" d=\"([^\"]*)\"")));
  EXPECT_EQ(Count(m[1].str(), "L"), 4u);  // two steps of two segments each
  EXPECT_NE(svg.find("stroke-dasharray"), std::string::npos);
  const size_t g = svg.find("class=\"pareto-markers\"");
  ASSERT_NE(g, std::string::npos);
  EXPECT_EQ(Count(svg.substr(g, svg.find("</g>", g) - g), "<circle"), 3u);
  EXPECT_NE(svg.find(">Pareto front</text>"), std::string::npos);
}

TEST(HeatMapSvg, CellsTextAndColourBar) {
  const HeatMap m = DemoMap();
  const std::string svg = HeatMapSvg(m);
  EXPECT_EQ(CheckXml(svg), "");
  EXPECT_EQ(Count(svg, "<rect class=\"cell\""), m.rows.size() * m.cols.size());
  std::set<std::pair<int, int>> cells;
  const std::regex re("<rect class=\"cell\" data-row=\"([0-9]+)\" data-col=\"([0-9]+)\"");
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), re); it != std::sregex_iterator();
       ++it) {
    cells.emplace(std::stoi((*it)[1].str()), std::stoi((*it)[2].str()));
  }
  EXPECT_EQ(cells.size(), m.rows.size() * m.cols.size());
  EXPECT_NE(svg.find("data-row=\"1\" data-col=\"2\" data-value=\"0.4\""), std::string::npos);
  for (const std::string& name : m.cols) {
    EXPECT_NE(svg.find("rotate(-45"), std::string::npos);
    EXPECT_NE(svg.find(">" + name + "</text>"), std::string::npos);
  }
  EXPECT_NE(svg.find("class=\"colour-bar\""), std::string::npos);
  EXPECT_GE(Count(svg, "class=\"cbar-tick\""), 3u);
  EXPECT_NE(svg.find(">error (dE)</text>"), std::string::npos);
  // Multi-line cell text: one <tspan> per line.
  EXPECT_NE(svg.find(">5°</tspan><tspan "), std::string::npos);
  EXPECT_NE(svg.find(">2 %</tspan></text>"), std::string::npos);
  // The NaN cell is hatched and says n/a.
  EXPECT_NE(svg.find("data-row=\"0\" data-col=\"3\" data-value=\"n/a\""), std::string::npos);
  EXPECT_NE(svg.find("fill=\"url(#mf-hatch-"), std::string::npos);
  EXPECT_NE(svg.find(">n/a</tspan>"), std::string::npos);
}

TEST(HeatMapSvg, TextContrastFollowsLuminance) {
  HeatMap m;
  m.rows = {"r"};
  m.cols = {"low", "high"};
  m.values = {0.0, 1.0};  // dark purple, bright yellow
  m.cell_text = {"dark", "bright"};
  const std::string svg = HeatMapSvg(m);
  EXPECT_NE(svg.find("fill=\"#ffffff\"><tspan"), std::string::npos);
  EXPECT_NE(svg.find("fill=\"#000000\"><tspan"), std::string::npos);
  EXPECT_LT(svg.find("fill=\"#ffffff\"><tspan"), svg.find(">dark<"));
  EXPECT_LT(svg.find("fill=\"#000000\"><tspan"), svg.find(">bright<"));
  EXPECT_GT(svg.find("fill=\"#000000\"><tspan"), svg.find(">dark<"));
}

TEST(HeatMapSvg, NonFiniteAndLogScaleNeverLeak) {
  HeatMap m = DemoMap();
  m.values[1] = kInf;
  m.values[2] = -kInf;
  m.values[5] = 0;      // clamps to vmin on the log scale
  m.values.pop_back();  // missing value: n/a
  m.log_scale = true;
  m.vmin = 0;  // invalid for a log scale: replaced by the smallest positive value
  m.vmax = 1;
  const std::string svg = Lower(HeatMapSvg(m));
  EXPECT_EQ(CheckXml(svg), "");
  EXPECT_EQ(svg.find("nan"), std::string::npos);
  EXPECT_EQ(svg.find("inf"), std::string::npos);
  EXPECT_EQ(Count(svg, "<rect class=\"cell\""), 12u);
  // Constant / inverted ranges do not divide by zero either.
  HeatMap flat = DemoMap();
  flat.vmin = flat.vmax = 0.5;
  EXPECT_EQ(Lower(HeatMapSvg(flat)).find("nan"), std::string::npos);
}

TEST(HeatMapSvg, EscapedAndEmpty) {
  HeatMap m;
  m.title = "A&B";
  m.rows = {"r<1>"};
  m.cols = {"c\"1\""};
  m.values = {0.5};
  m.cell_text = {"x<y\n'z'"};
  const std::string svg = HeatMapSvg(m);
  EXPECT_EQ(CheckXml(svg), "");
  EXPECT_NE(svg.find(">r&lt;1&gt;</text>"), std::string::npos);
  EXPECT_NE(svg.find(">c&quot;1&quot;</text>"), std::string::npos);
  EXPECT_NE(svg.find(">x&lt;y</tspan>"), std::string::npos);
  EXPECT_NE(svg.find(">&apos;z&apos;</tspan>"), std::string::npos);
  const std::string empty = HeatMapSvg(HeatMap{});
  EXPECT_EQ(CheckXml(empty), "");
  EXPECT_NE(empty.find(">no data</text>"), std::string::npos);
}

TEST(ExternalTools, XmllintAcceptsOutput) {
  if (!std::filesystem::exists("/usr/bin/xmllint")) GTEST_SKIP() << "/usr/bin/xmllint not found";
  const std::filesystem::path dir = TempDir();
  int i = 0;
  for (const std::string& svg : {XYChartSvg(DemoChart()), HeatMapSvg(DemoMap()),
                                 XYChartSvg(XYChart{}), HeatMapSvg(HeatMap{})}) {
    const std::filesystem::path p = dir / ("lint" + std::to_string(i++) + ".svg");
    WriteFile(p, svg);
    const std::string cmd = "/usr/bin/xmllint --noout '" + p.string() + "'";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << p;
  }
}

TEST(ExternalTools, RsvgConvertRendersPng) {
  if (!std::filesystem::exists("/usr/bin/rsvg-convert")) {
    GTEST_SKIP() << "/usr/bin/rsvg-convert not found";
  }
  const std::filesystem::path dir = TempDir();
  int i = 0;
  for (const std::string& svg : {XYChartSvg(DemoChart()), HeatMapSvg(DemoMap())}) {
    const std::filesystem::path in = dir / ("render" + std::to_string(i) + ".svg");
    const std::filesystem::path out = dir / ("render" + std::to_string(i++) + ".png");
    WriteFile(in, svg);
    std::filesystem::remove(out);
    const std::string cmd = "/usr/bin/rsvg-convert -o '" + out.string() + "' '" + in.string() + "'";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    ASSERT_TRUE(std::filesystem::exists(out));
    EXPECT_GT(std::filesystem::file_size(out), 0u);
  }
}

}  // namespace
}  // namespace matfit::eval
