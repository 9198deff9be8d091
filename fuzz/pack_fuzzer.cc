// Material packs (core/pack/pack_reader.cc): material.json is the input, in a pack folder whose
// maps a real 4×4 Lambert and PTM pack wrote (so valid map names reach the image checks).
#include <cstddef>
#include <cstdint>
#include <filesystem>

#include "core/material_maps.h"
#include "core/model/model.h"
#include "core/pack/pack.h"
#include "core/pack/pack_reader.h"
#include "fuzz/fuzz_util.h"

using namespace matfit;
namespace fs = std::filesystem;

namespace {

std::string MakePackDir() {
  const std::string d = fuzz::ScratchDir() + "/pack";
  fs::create_directories(d);
  for (const char* name : {"lambert", "ptm", "rbf"}) {
    MaterialMaps m;
    m.width = m.height = 4, m.model = ModelId(name);
    m.normal = Image(4, 4, 3, 0.0f);
    for (int p = 0; p < 16; ++p) m.normal.Plane(2)[p] = 1;
    m.albedo = Image(4, 4, 3, 0.5f);
    m.mask = Image(4, 4, 1, 1.0f);
    if (std::string(name) == "ptm") m.basis_terms = 6, m.coefficients = Image(4, 4, 18, 0.1f);
    if (std::string(name) == "rbf")  // a table the fuzzed material.json can point anywhere
      m.basis_terms = 2, m.coefficients = Image(4, 4, 6, 0.1f),
      m.basis_table = Image(3, 3, 2, 0.5f);
    const std::string out = fuzz::ScratchDir() + "/" + name;
    if (!WritePack(m, std::vector<uint8_t>(16, 0), {}, {}, out).ok()) std::abort();
    for (const auto& e : fs::recursive_directory_iterator(out)) {  // merge both packs' maps
      const fs::path rel = fs::relative(e.path(), out), to = fs::path(d) / rel;
      if (e.is_directory())
        fs::create_directories(to);
      else if (!fs::exists(to))
        fs::copy_file(e.path(), to);
    }
  }
  return d;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string dir = MakePackDir();
  fuzz::WriteBytes(dir + "/material.json", data, size);
  (void)ReadPack(dir);
  return 0;
}
