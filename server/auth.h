// Bearer-token authorisation. Tokens come from a file, one per line: `TOKEN [write|read]`
// (default write; `#` starts a comment). Comparison is constant-time in the token contents.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"

namespace matfit::server {

// Equal strings; the time taken depends only on the lengths, not on where they differ.
bool ConstantTimeEquals(std::string_view a, std::string_view b);

enum class Access { kRead, kWrite };
enum class AuthResult {
  kOk,
  kMissing,    // no `Authorization: Bearer …` header → 401
  kInvalid,    // a token that is not in the file → 401
  kForbidden,  // a read-only token on a write endpoint → 403
};

class TokenSet {
 public:
  TokenSet() = default;
  // Errors name the file and line (tokens must be ≥ 16 characters of [A-Za-z0-9._~+/=-]).
  static StatusOr<TokenSet> Load(const std::string& path);
  static TokenSet FromList(std::vector<std::pair<std::string, bool>> tokens);  // token, write
  bool empty() const { return tokens_.empty(); }
  size_t size() const { return tokens_.size(); }
  // `authorization` is the raw header value ("Bearer abc…"), possibly empty.
  AuthResult Check(const std::string& authorization, Access need) const;

 private:
  struct Entry {
    std::string token;
    bool write = true;
  };
  std::vector<Entry> tokens_;
};

}  // namespace matfit::server
