#include "core/dataset/btf_names.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <regex>

namespace matfit {
namespace {

// Digit counts are bounded so that the numeric conversions below cannot overflow.
const std::regex& BonnRegex() {
  static const std::regex re(
      R"(^(\d{1,9}) tl(\d{1,3}) pl(\d{1,3}) tv(\d{1,3}) pv(\d{1,3})\.[A-Za-z0-9]+$)");
  return re;
}
const std::regex& UtiaRegex() {
  static const std::regex re(
      R"(^tl(\d{1,3}(?:\.\d{1,6})?)_pl(\d{1,3}(?:\.\d{1,6})?)_tv(\d{1,3}(?:\.\d{1,6})?)_pv(\d{1,3}(?:\.\d{1,6})?)\.[A-Za-z0-9]+$)");
  return re;
}

std::string Angle(double deg) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%07.3f", deg);
  std::string s = buf;
  while (s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s;
}

}  // namespace

bool ParseBonnName(const std::string& filename, BtfName* out) {
  std::smatch m;
  if (!std::regex_match(filename, m, BonnRegex())) return false;
  out->index = std::stoi(m[1].str());
  out->theta_l = std::stod(m[2].str());
  out->phi_l = std::stod(m[3].str());
  out->theta_v = std::stod(m[4].str());
  out->phi_v = std::stod(m[5].str());
  return true;
}

bool ParseUtiaName(const std::string& filename, BtfName* out) {
  std::smatch m;
  if (!std::regex_match(filename, m, UtiaRegex())) return false;
  out->index = -1;
  out->theta_l = std::stod(m[1].str());
  out->phi_l = std::stod(m[2].str());
  out->theta_v = std::stod(m[3].str());
  out->phi_v = std::stod(m[4].str());
  return true;
}

std::string MakeBonnName(int index, const BtfName& a, const std::string& ext) {
  char buf[96];
  std::snprintf(buf, sizeof buf, "%05d tl%03ld pl%03ld tv%03ld pv%03ld", index,
                std::lround(a.theta_l), std::lround(a.phi_l), std::lround(a.theta_v),
                std::lround(a.phi_v));
  return buf + ext;
}

std::string MakeUtiaName(const BtfName& a, const std::string& ext) {
  return "tl" + Angle(a.theta_l) + "_pl" + Angle(a.phi_l) + "_tv" + Angle(a.theta_v) + "_pv" +
         Angle(a.phi_v) + ext;
}

std::string MakeBonnViewFolder(double theta_v, double phi_v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "tv%03ld_pv%03ld", std::lround(theta_v), std::lround(phi_v));
  return buf;
}

bool IsImageExtension(const std::string& ext) {
  std::string e = ext;
  std::transform(e.begin(), e.end(), e.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* known : kImageExtensions)
    if (e == known) return true;
  return false;
}

}  // namespace matfit
