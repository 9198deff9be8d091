// Job submissions (server/job_spec.cc): the JSON body of POST /api/v1/jobs, and a stored spec.
#include <cstddef>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "server/job_spec.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  std::string dataset;
  auto spec = matfit::server::ParseJobSpecJson(text, &dataset);
  if (spec.ok()) {  // what is accepted round-trips through the stored form
    auto back = matfit::server::JobSpecFromJson(spec->ToJson().dump());
    if (!back.ok() || back->ToJson() != spec->ToJson()) __builtin_trap();
  }
  (void)matfit::server::JobSpecFromJson(text);
  return 0;
}
