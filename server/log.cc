#include "server/log.h"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <nlohmann/json.hpp>

#include "server/text.h"

namespace matfit::server {
namespace {
std::atomic<bool> g_quiet{false};
std::mutex g_mutex;
}  // namespace

void SetLogQuiet(bool quiet) { g_quiet = quiet; }

void LogEvent(const char* level, const char* event, const nlohmann::json& fields) {
  if (g_quiet && std::string(level) != "error") return;
  const auto now = std::chrono::system_clock::now();
  const std::time_t t = std::chrono::system_clock::to_time_t(now);
  const int ms = int(
      std::chrono::duration_cast<std::chrono::milliseconds>(now.time_since_epoch()).count() % 1000);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char ts[96];
  std::snprintf(ts, sizeof ts, "%04d-%02d-%02dT%02d:%02d:%02d.%03dZ", tm.tm_year + 1900,
                tm.tm_mon + 1, tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec, ms);
  nlohmann::json line = {{"ts", ts}, {"level", level}, {"event", event}};
  if (fields.is_object())
    for (const auto& [k, v] : fields.items()) line[k] = v;
  const std::string text = JsonText(line);
  std::lock_guard<std::mutex> lock(g_mutex);
  std::fprintf(stderr, "%s\n", text.c_str());
}

}  // namespace matfit::server
