// SVG building blocks shared by the chart writers (eval/chart.h): number formatting without
// locale, text metrics, colours (a qualitative palette and viridis), primitives, axis ranges and
// ticks. Internal to matfit_eval.
#pragma once

#include <array>
#include <charconv>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace matfit::eval::svg {

struct Rgb {
  double r, g, b;  // sRGB in [0, 1]
};

inline constexpr std::array<uint32_t, 10> kPalette = {0x1f77b4, 0xff7f0e, 0x2ca02c, 0xd62728,
                                                      0x9467bd, 0x8c564b, 0xe377c2, 0x7f7f7f,
                                                      0xbcbd22, 0x17becf};

inline constexpr std::array<uint32_t, 6> kViridis = {0x440154, 0x414487, 0x2a788e,
                                                     0x22a884, 0x7ad151, 0xfde725};

inline constexpr int kNumShapes = 5;

struct Decades {
  int e0, e1, stride;
};

std::string ToChars(double v, std::chars_format fmt, int precision);
std::string TidyExponent(const std::string& s);
std::string TrimZeros(const std::string& s);
std::string Num(double v, int digits = 6);
std::string Px(double v);
double TextWidth(std::string_view s, double font_size);
std::vector<std::string> SplitLines(const std::string& s);
std::string Hex(const Rgb& c);
Rgb FromHex(uint32_t h);
double Luminance(const Rgb& c);
const char* TextColourOn(const Rgb& bg);
Rgb Viridis(double t);
std::string SvgOpen(double width, double height, const std::string& title);
std::string Text(double x, double y, const std::string& text, const std::string& extra);
std::string Line(double x1, double y1, double x2, double y2, const std::string& extra);
std::string Rect(double x, double y, double w, double h, const std::string& extra);
std::string Marker(int shape, double x, double y);
bool Usable(double v, bool log);
void PadRange(double& lo, double& hi, bool log, bool have_data);
std::vector<double> LinearTicks(double lo, double hi, int target);
Decades LogDecades(double lo, double hi, int target);
std::vector<double> MinorTicks(double lo, double hi, bool log, int target);
std::vector<double> TicksInRange(std::vector<double> ticks, double lo, double hi);

}  // namespace matfit::eval::svg
