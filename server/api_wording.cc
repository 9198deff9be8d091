#include "server/api_wording.h"

#include <cctype>
#include <utility>

namespace matfit::server {
namespace {

// flag → job field (POST /api/v1/jobs); flags not listed have no field.
constexpr std::pair<const char*, const char*> kFields[] = {
    {"layout", "layout"}, {"color-space", "color_space"}, {"view", "view"}, {"holdout", "holdout"},
    {"model", "model"},   {"budget", "budget"},
};

bool FlagChar(char c) { return std::islower(static_cast<unsigned char>(c)) || c == '-'; }

}  // namespace

std::string ApiWording(std::string m) {
  // Phrases first, so that the result reads as an instruction to an API client:
  // "pass --layout lp or --layout bonn" → "set the job field "layout" to lp or to bonn".
  auto replace_all = [&](const std::string& from, const std::string& to) {
    for (size_t at = 0; (at = m.find(from, at)) != std::string::npos; at += to.size())
      m.replace(at, from.size(), to);
  };
  replace_all("(--color-space srgb)", "(job field \"color_space\": \"srgb\")");
  for (const auto& [flag, field] : kFields) {
    const std::string f = std::string("--") + flag, api = std::string("\"") + field + "\"";
    replace_all("pass " + f + " ", "set the job field " + api + " to ");
    replace_all(" or " + f + " ", " or to ");
    replace_all("pass " + f, "set the job field " + api);
  }
  // Then every remaining "--flag".
  std::string out;
  for (size_t i = 0; i < m.size();) {
    const bool flag = m.compare(i, 2, "--") == 0 && i + 2 < m.size() &&
                      std::islower(static_cast<unsigned char>(m[i + 2])) &&
                      (i == 0 || !FlagChar(m[i - 1]));
    if (!flag) {
      out += m[i++];
      continue;
    }
    size_t j = i + 2;
    while (j < m.size() && FlagChar(m[j])) ++j;
    const std::string name = m.substr(i + 2, j - i - 2);
    const char* field = nullptr;
    for (const auto& [f, api] : kFields)
      if (name == f) field = api;
    out += field ? "job field \"" + std::string(field) + "\""
                 : "the '" + name + "' setting (not a job field)";
    i = j;
  }
  return out;
}

}  // namespace matfit::server
