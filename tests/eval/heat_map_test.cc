// Heat maps: cells, colour bar, contrast, non-finite values.
#include "chart_test_util.h"

namespace matfit::eval {
namespace {

using namespace chart_testing;  // NOLINT

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

}  // namespace
}  // namespace matfit::eval
