// Structured logs: one JSON object per line on stderr ({"ts", "level", "event", ...fields}).
#pragma once

#include <nlohmann/json_fwd.hpp>
#include <string>

namespace matfit::server {

void SetLogQuiet(bool quiet);  // tests silence the request log
void LogEvent(const char* level, const char* event, const nlohmann::json& fields);

}  // namespace matfit::server
