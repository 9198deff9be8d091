// Capture plans (capture/session.cc ReadPlan): the plan file is the input.
#include <cstddef>
#include <cstdint>

#include "capture/session.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = matfit::fuzz::ScratchDir() + "/plan.json";
  matfit::fuzz::WriteBytes(path, data, size);
  (void)matfit::capture::ReadPlan(path);
  return 0;
}
