// Line-oriented text files (light lists, manifests) with file:line error messages.
#pragma once

#include <string>
#include <vector>

#include "core/status.h"

namespace matfit {

struct TextLine {
  int number = 0;                   // 1-based line number in the file
  std::string text;                 // without the newline and surrounding white space
  std::vector<std::string> tokens;  // split on white space
};

// Reads the non-empty lines of `path` that are not comments ('#' first). With `confine_to`, the
// file must resolve inside that folder (ResolveInDataset: the server's dataset sandbox).
StatusOr<std::vector<TextLine>> ReadTextLines(const std::string& path,
                                              const std::string& confine_to = "");

// Strict number parsing: the whole token must be a finite number.
bool ParseFiniteDouble(const std::string& token, double* out);
bool ParseInt(const std::string& token, int* out);

// "file:line: message".
std::string AtLine(const std::string& path, int line, const std::string& message);

}  // namespace matfit
