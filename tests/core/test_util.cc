#include "tests/core/test_util.h"

#include "core/dataset/writer.h"
#include "core/stack_ops.h"
#include "core/synth/synth.h"

#include <unistd.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace matfit::testing {

namespace fs = std::filesystem;

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = info ? std::string(info->test_suite_name()) + "." + info->name() : "test";
  for (char& c : name)
    if (c == '/') c = '_';
  path_ = (fs::temp_directory_path() /
           ("matfit-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-" + name))
              .string();
  fs::remove_all(path_);
  fs::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::string SharedDataDir() {
  if (const char* env = std::getenv("MATFIT_SHARED_DATA")) return env;
  std::error_code ec;
  return fs::is_directory(MATFIT_SHARED_DATA, ec) ? std::string(MATFIT_SHARED_DATA) : std::string();
}

double MaxAbsDiff(const LightStack& a, const LightStack& b) {
  EXPECT_EQ(a.width(), b.width());
  EXPECT_EQ(a.height(), b.height());
  EXPECT_EQ(a.channels(), b.channels());
  EXPECT_EQ(a.num_images(), b.num_images());
  double m = 0;
  for (int i = 0; i < a.num_images(); ++i)
    for (int c = 0; c < a.channels(); ++c)
      for (int64_t p = 0; p < a.plane_size(); ++p)
        m = std::max(m, double(std::abs(a.Sample(i, c, p) - b.Sample(i, c, p))));
  return m;
}

void WriteText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

Image WavePattern(int w, int h, int ch) {
  Image img(w, h, ch);
  for (int c = 0; c < ch; ++c)
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x)
        img.Plane(c)[size_t(y) * w + x] =
            0.5f + 0.45f * std::sin(0.21f * x + 1.3f * c) * std::cos(0.17f * y - 0.4f * c);
  return img;
}

LightStack WriteSynthSet(const std::string& dir, const std::string& name, Layout layout, int bits) {
  synth::SynthOptions o;
  o.material = "plaster";
  o.lights = "dome:12";
  o.size = 20;
  o.layout = layout;
  o.bits = bits;
  auto r = synth::Synthesize(o);
  EXPECT_TRUE(r.ok()) << r.status().ToString();
  auto crop = CropStack(r->stack, 0, 0, 20, 16);  // non-square: rows and columns differ
  EXPECT_TRUE(crop.ok());
  DatasetWriteOptions wo;
  wo.layout = layout;
  wo.bits = bits;
  wo.object_name = name;
  const std::string out = dir + "/" + name;
  std::filesystem::create_directories(out);
  EXPECT_TRUE(WriteDataset(*crop, wo, out).ok());
  return std::move(*crop);
}

}  // namespace matfit::testing
