// XY charts, ticks, Pareto fronts, escaping and the external SVG tools.
#include "chart_test_util.h"

namespace matfit::eval {
namespace {

using namespace chart_testing;  // NOLINT

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
