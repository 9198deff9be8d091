#include "server/auth.h"

#include <openssl/evp.h>
#include <openssl/rand.h>

#include <fstream>
#include <sstream>

namespace matfit::server {

bool ConstantTimeEquals(std::string_view a, std::string_view b) {
  const size_t n = std::max(a.size(), b.size());
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (size_t i = 0; i < n; ++i) {
    const unsigned char x = i < a.size() ? a[i] : 0, y = i < b.size() ? b[i] : 0;
    diff |= unsigned(x ^ y);
  }
  return diff == 0;
}

std::string Sha256Hex(std::string_view data) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  EVP_Digest(data.data(), data.size(), md, &n, EVP_sha256(), nullptr);
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (unsigned i = 0; i < n; ++i) out += kHex[md[i] >> 4], out += kHex[md[i] & 15];
  return out;
}

StatusOr<std::string> NewToken() {
  unsigned char b[33] = {0};
  if (RAND_bytes(b, 32) != 1) return Status(StatusCode::kInternal, "no random bytes for a token");
  static constexpr char kB64[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789-_";
  std::string out;  // base64url without padding: 32 bytes → 43 characters
  for (int i = 0; i < 32; i += 3) {
    const unsigned v = unsigned(b[i]) << 16 | unsigned(b[i + 1]) << 8 | unsigned(b[i + 2]);
    for (int k = 0; k < 4 && out.size() < 43; ++k) out += kB64[(v >> (18 - 6 * k)) & 63];
  }
  return out;
}

void TokenSet::AddHashed(const std::string& sha256_hex, bool write) {
  tokens_.push_back({sha256_hex, write, true});
}

StatusOr<TokenSet> TokenSet::Load(const std::string& path) {
  std::ifstream in(path);
  if (!in) return NotFound("cannot open token file '" + path + "'");
  TokenSet set;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (const auto hash = line.find('#'); hash != std::string::npos) line.resize(hash);
    std::istringstream words(line);
    std::string token, role, extra;
    if (!(words >> token)) continue;
    words >> role >> extra;
    const std::string where = path + ":" + std::to_string(number);
    if (!extra.empty())
      return DataError(where + ": expected `TOKEN [write|read]`, found more words");
    if (token.size() < 16)
      return DataError(where + ": token is " + std::to_string(token.size()) +
                       " characters; use at least 16 (e.g. `openssl rand -hex 24`)");
    for (char c : token)
      if (!(std::isalnum(static_cast<unsigned char>(c)) ||
            std::string_view("._~+/=-_").find(c) != std::string_view::npos))
        return DataError(where + ": token has a character outside [A-Za-z0-9._~+/=_-]");
    if (!role.empty() && role != "write" && role != "read")
      return DataError(where + ": role '" + role + "' must be write or read");
    set.tokens_.push_back({token, role != "read"});
  }
  if (set.tokens_.empty())
    return DataError("token file '" + path + "' has no tokens; add one per line");
  return set;
}

TokenSet TokenSet::FromList(std::vector<std::pair<std::string, bool>> tokens) {
  TokenSet set;
  for (auto& [t, w] : tokens) set.tokens_.push_back({std::move(t), w});
  return set;
}

AuthResult TokenSet::Check(const std::string& authorization, Access need) const {
  constexpr std::string_view kBearer = "Bearer ";
  if (authorization.size() <= kBearer.size() ||
      authorization.compare(0, kBearer.size(), kBearer) != 0)
    return AuthResult::kMissing;
  const std::string_view given = std::string_view(authorization).substr(kBearer.size());
  // Every token is compared (no early exit), so timing reveals neither which nor how much.
  int match = -1;
  std::string given_hash;
  for (size_t i = 0; i < tokens_.size(); ++i) {
    if (tokens_[i].hashed && given_hash.empty()) given_hash = Sha256Hex(given);
    if (ConstantTimeEquals(tokens_[i].hashed ? std::string_view(given_hash) : given,
                           tokens_[i].token))
      match = int(i);
  }
  if (match < 0) return AuthResult::kInvalid;
  if (need == Access::kWrite && !tokens_[size_t(match)].write) return AuthResult::kForbidden;
  return AuthResult::kOk;
}

}  // namespace matfit::server
