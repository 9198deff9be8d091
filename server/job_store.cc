#include "server/job_store.h"

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
  // ...?password=pw&... → ...?password=***&...
  for (size_t p = out.find("password="); p != std::string::npos; p = out.find("password=", p + 1)) {
    const size_t v = p + 9, end = out.find('&', v);
    out.replace(v, (end == std::string::npos ? out.size() : end) - v, "***");
  }
  return out;
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
