#include "server/job_store.h"

#include <algorithm>
#include <cctype>
#include <cstdint>

namespace matfit::server {
namespace {

constexpr const char* kStates[] = {"queued", "running", "succeeded", "failed", "cancelled"};

}  // namespace

const char* JobStateName(JobState s) { return kStates[int(s)]; }

bool ParseJobState(const std::string& s, JobState* out) {
  for (int i = 0; i < 5; ++i)
    if (s == kStates[i]) return *out = JobState(i), true;
  return false;
}

bool IsPostgresUrl(const std::string& s) {
  return s.rfind("postgresql://", 0) == 0 || s.rfind("postgres://", 0) == 0;
}

std::string RedactDatabaseUrl(const std::string& url) {
  std::string out = url;
  // scheme://user:password@host... → scheme://user:***@host...
  const size_t scheme = out.find("://");
  const size_t at = scheme == std::string::npos ? scheme : out.find('@', scheme + 3);
  const size_t colon = at == std::string::npos ? at : out.find(':', scheme + 3);
  if (colon != std::string::npos && colon < at)
    out = out.substr(0, colon + 1) + "***" + out.substr(at);
  // ...?password=pw&... → ...?password=***&... (libpq decodes %xx in names too: pass%77ord)
  const size_t query = out.find('?');
  if (query == std::string::npos) return out;
  std::string redacted = out.substr(0, query + 1);
  size_t p = query + 1;
  while (p <= out.size()) {
    const size_t end = std::min(out.find('&', p), out.size());
    const std::string param = out.substr(p, end - p);
    const size_t eq = param.find('=');
    std::string key;
    for (size_t i = 0; i < std::min(eq, param.size()); ++i) {
      if (param[i] == '%' && i + 2 < param.size() && std::isxdigit(uint8_t(param[i + 1])) &&
          std::isxdigit(uint8_t(param[i + 2]))) {
        key += char(std::stoi(param.substr(i + 1, 2), nullptr, 16));
        i += 2;
      } else {
        key += param[i];
      }
    }
    for (char& c : key) c = char(std::tolower(uint8_t(c)));
    redacted += key == "password" && eq != std::string::npos ? param.substr(0, eq) + "=***" : param;
    if (end < out.size()) redacted += '&';
    p = end + 1;
  }
  return redacted;
}

namespace {
Status NoTokenTable() {
  return Status(StatusCode::kUnavailable,
                "tokens in the database need a cluster's job database (--db postgresql://…); a "
                "single matfit serve takes its tokens from --token-file");
}
}  // namespace

StatusOr<std::vector<StoredToken>> JobStore::ListTokens() { return NoTokenTable(); }
Status JobStore::AddToken(const StoredToken&) { return NoTokenTable(); }
StatusOr<int> JobStore::RevokeTokens(const std::string&, const std::string&) {
  return NoTokenTable();
}

#ifndef MATFIT_HAVE_POSTGRES
StatusOr<std::unique_ptr<JobStore>> OpenPostgresJobStore(const std::string&) {
  return Status(StatusCode::kUnavailable,
                "this matfit was built without PostgreSQL support (libpqxx-dev was not found); "
                "install it (scripts/install-deps.sh) and rebuild, or leave out --db to keep "
                "the jobs in DATA/jobs.db (SQLite)");
}
#endif

}  // namespace matfit::server
