// Bearer-token authorisation. Tokens come from a file, one per line: `TOKEN [write|read]`
// (default write; `#` starts a comment), and in a cluster also from the job database, which
// keeps only their SHA-256. Comparison is constant-time in the token contents.
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "core/status.h"

namespace matfit::server {

// Equal strings; the time taken depends only on the lengths, not on where they differ.
bool ConstantTimeEquals(std::string_view a, std::string_view b);
// SHA-256 of `data` as 64 lowercase hex digits (how a cluster's database keeps tokens).
std::string Sha256Hex(std::string_view data);
// A new random token: 32 bytes from the OS's generator, as 43 base64url characters.
StatusOr<std::string> NewToken();

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
  // Errors name the file and line (tokens must be ≥ 16 characters of [A-Za-z0-9._~+/=_-]).
  static StatusOr<TokenSet> Load(const std::string& path);
  static TokenSet FromList(std::vector<std::pair<std::string, bool>> tokens);  // token, write
  // Adds a token known only by its SHA-256 (Sha256Hex), e.g. from the cluster's database.
  void AddHashed(const std::string& sha256_hex, bool write);
  bool empty() const { return tokens_.empty(); }
  size_t size() const { return tokens_.size(); }
  // `authorization` is the raw header value ("Bearer abc…"), possibly empty.
  AuthResult Check(const std::string& authorization, Access need) const;

 private:
  struct Entry {
    std::string token;  // the token, or its SHA-256 hex when `hashed`
    bool write = true;
    bool hashed = false;
  };
  std::vector<Entry> tokens_;
};

}  // namespace matfit::server
