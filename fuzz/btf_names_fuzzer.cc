// Bonn/UTIA BTF file names (core/dataset/btf_names.cc): any name parses or is refused; a parsed
// name has finite angles, and a view folder name can be made from them.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>

#include "core/dataset/btf_names.h"

using namespace matfit;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string name(reinterpret_cast<const char*>(data), size);
  BtfName b;
  if (ParseBonnName(name, &b) && !(std::isfinite(b.theta_l) && std::isfinite(b.phi_l) &&
                                   std::isfinite(b.theta_v) && std::isfinite(b.phi_v)))
    std::abort();  // a parsed name has finite angles
  BtfName u;
  if (ParseUtiaName(name, &u) && !(std::isfinite(u.theta_l) && std::isfinite(u.phi_l) &&
                                   std::isfinite(u.theta_v) && std::isfinite(u.phi_v)))
    std::abort();
  (void)MakeBonnViewFolder(b.theta_v, b.phi_v);
  return 0;
}
