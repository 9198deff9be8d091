// Scene descriptions for --model auto (fit/select.cc ParseScene): the JSON text is the input.
#include <cstddef>
#include <cstdint>
#include <string>

#include "fit/select.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  (void)matfit::fit::ParseScene(std::string(reinterpret_cast<const char*>(data), size),
                                "scene.json");
  return 0;
}
