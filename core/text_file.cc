#include "core/text_file.h"

#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/path_util.h"

namespace matfit {

StatusOr<std::vector<TextLine>> ReadTextLines(const std::string& path,
                                              const std::string& confine_to) {
  auto real = ResolveInDataset(path, confine_to);
  if (!real.ok()) return real.status();
  std::error_code ec;
  if (!std::filesystem::is_regular_file(*real, ec))
    return NotFound("file '" + DatasetRelative(path, confine_to) + "' does not exist");
  std::ifstream in(*real);
  if (!in) return IoError("cannot open '" + path + "'");
  std::vector<TextLine> lines;
  std::string raw;
  int number = 0;
  while (std::getline(in, raw)) {
    ++number;
    if (!raw.empty() && raw.back() == '\r') raw.pop_back();  // CRLF files
    const auto first = raw.find_first_not_of(" \t");
    if (first == std::string::npos || raw[first] == '#') continue;
    const auto last = raw.find_last_not_of(" \t");
    TextLine line;
    line.number = number;
    line.text = raw.substr(first, last - first + 1);
    std::istringstream ss(line.text);
    for (std::string tok; ss >> tok;) line.tokens.push_back(tok);
    lines.push_back(std::move(line));
  }
  if (in.bad()) return IoError("reading '" + path + "' failed");
  return lines;
}

bool ParseFiniteDouble(const std::string& token, double* out) {
  const char* b = token.data();
  const char* e = b + token.size();
  if (b != e && *b == '+') ++b;
  double v = 0;
  auto [ptr, err] = std::from_chars(b, e, v);
  if (err != std::errc() || ptr != e || !std::isfinite(v)) return false;
  *out = v;
  return true;
}

bool ParseInt(const std::string& token, int* out) {
  int v = 0;
  auto [ptr, err] = std::from_chars(token.data(), token.data() + token.size(), v);
  if (err != std::errc() || ptr != token.data() + token.size()) return false;
  *out = v;
  return true;
}

std::string AtLine(const std::string& path, int line, const std::string& message) {
  return path + ":" + std::to_string(line) + ": " + message;
}

}  // namespace matfit
