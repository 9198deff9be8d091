// Fits on a stack held at native depth (uint8 / uint16 codes + table) equal fits on the same
// stack held as float32 (LightStack::ToFloat): the kernels read linear values through the table
// that the decoder uses, in the same order, so the maps agree to rounding (here: exactly).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/stack_ops.h"
#include "fit/confidence.h"
#include "fit/holdout.h"
#include "fit/method.h"
#include "fit/methods.h"
#include "fit/metrics.h"
#include "tests/fit/synth_data.h"

namespace matfit::fit {
namespace {

void ExpectSameMaps(const MaterialMaps& a, const MaterialMaps& b, const std::string& what) {
  const std::pair<const Image*, const Image*> planes[] = {{&a.normal, &b.normal},
                                                          {&a.albedo, &b.albedo},
                                                          {&a.ambient, &b.ambient},
                                                          {&a.normal_scale, &b.normal_scale},
                                                          {&a.specular, &b.specular},
                                                          {&a.exponent, &b.exponent},
                                                          {&a.roughness, &b.roughness},
                                                          {&a.specular_color, &b.specular_color},
                                                          {&a.coefficients, &b.coefficients}};
  for (const auto& [x, y] : planes) {
    ASSERT_EQ(x->data().size(), y->data().size()) << what;
    for (size_t k = 0; k < x->data().size(); ++k) {
      const float u = x->data()[k], v = y->data()[k];
      if (std::isnan(u) && std::isnan(v)) continue;
      ASSERT_NEAR(u, v, 1e-6) << what << " sample " << k;
    }
  }
}

void CompareMethods(const LightStack& native, const std::vector<std::string>& methods) {
  ASSERT_FALSE(native.is_float());
  const LightStack f = native.ToFloat();
  ASSERT_TRUE(f.is_float());
  for (const std::string& name : methods) {
    auto method = MakeMethod(name);
    ASSERT_TRUE(method) << name;
    auto a = method->Fit(native, {}), b = method->Fit(f, {});
    ASSERT_TRUE(a.ok()) << name << ": " << a.status().ToString();
    ASSERT_TRUE(b.ok()) << name << ": " << b.status().ToString();
    EXPECT_EQ(a->status, b->status) << name;
    EXPECT_EQ(a->flagged_texels, b->flagged_texels) << name;
    ExpectSameMaps(a->maps, b->maps, name);
    for (const auto& [k, v] : b->parameters) EXPECT_NEAR(a->parameters[k], v, 1e-6) << name << k;
    const auto ra = Reconstruction(native, a->maps, a->status);
    const auto rb = Reconstruction(f, b->maps, b->status);
    EXPECT_NEAR(ra.rmse, rb.rmse, 1e-9) << name;
  }
}

TEST(NativeDepth, EightBitSrgbFitsEqualFloatFits) {
  // Plastic with noise and clipping: highlights, clipped samples and shadows exercise the
  // flags and the per-sample rejection; 61 × 47 leaves kernel tails.
  auto data = SynthData({"plastic", "dome:40", 61, 0.01});
  for (int i = 0; i < data.stack.num_images(); ++i)
    for (int c = 0; c < 3; ++c)
      for (float& v : data.stack.Plane(i, c)) v = std::min(v * 1.6f, 1.0f);
  const LightStack q = QuantiseStack(data.stack, 8);
  int64_t sat = 0;
  for (int64_t v : q.saturated_pixels) sat += v;
  EXPECT_GT(sat, 0) << "the test needs clipped samples";
  // The sRGB-domain fits read 8-bit codes through one encode table per code (no per-sample
  // decode and encode): the same values as the float path's encode of each decoded sample.
  CompareMethods(q, {"mean", "lambert", "lambert-robust", "heinrich", "ptm", "hsh2", "hsh3",
                     "blinn-phong", "ptm-srgb", "hsh2-srgb", "rbf", "rbf-srgb"});
}

TEST(NativeDepth, EightBitReferencesEqualFloat) {
  const LightStack q = QuantiseStack(SynthData({"wool", "bonn81", 24, 0.01}).stack, 8);
  const LightStack f = q.ToFloat();
  using Fn = StatusOr<FitResult> (*)(const LightStack&, const FitOptions&);
  for (Fn fn : {Fn(FitLambertReference), Fn(FitPtmReference), Fn(FitHeinrichReference)}) {
    auto a = fn(q, {}), b = fn(f, {});
    ASSERT_TRUE(a.ok() && b.ok());
    EXPECT_EQ(a->status, b->status);
    ExpectSameMaps(a->maps, b->maps, a->method);
  }
}

TEST(NativeDepth, SixteenBitLinearFitsEqualFloatFits) {
  auto data = SynthData({"granite", "bonn81", 40, 0.005});
  CompareMethods(QuantiseStack(data.stack, 16),
                 {"lambert", "ptm", "heinrich", "lambert-robust", "ptm-srgb", "rbf-srgb"});
}

TEST(NativeDepth, GreyStackAndMask) {
  auto data = SynthData({"plaster", "dome:24", 33, 0.01});
  LightStack grey(33, 33, 1, data.stack.num_images());
  grey.lights() = data.stack.lights();
  for (int i = 0; i < grey.num_images(); ++i)
    for (int64_t p = 0; p < grey.plane_size(); ++p)
      grey.Plane(i, 0)[p] = data.stack.Sample(i, 1, p);
  grey.mask.assign(size_t(grey.plane_size()), 1);
  for (int64_t p = 0; p < grey.plane_size(); p += 7) grey.mask[p] = 0;
  CompareMethods(QuantiseStack(grey, 8),
                 {"mean", "lambert", "ptm", "heinrich", "lambert-robust", "hsh3-srgb"});
}

TEST(NativeDepth, ConfidenceEqualsFloat) {
  const LightStack q = QuantiseStack(SynthData({"plaster", "dome:30", 24, 0.01}).stack, 8);
  const LightStack f = q.ToFloat();
  auto fit = FitLambert(f, {});
  ASSERT_TRUE(fit.ok());
  const ModelSize size{5, 1, 3};
  std::vector<uint8_t> sa = fit->status, sb = fit->status;
  const auto a = ComputeConfidence(q, fit->maps, size, &sa);
  const auto b = ComputeConfidence(f, fit->maps, size, &sb);
  EXPECT_EQ(a.bound, b.bound);
  EXPECT_EQ(sa, sb);
}

TEST(NativeDepth, HeldOutFoldsKeepTheSampleType) {
  const LightStack f = SynthData({"plaster", "dome:12", 8}).stack;
  const std::vector<int> pick = {3, 1, 7, 11, 0};
  for (const LightStack& s : {QuantiseStack(f, 8), QuantiseStack(f, 16), f}) {
    const LightStack some = SelectImages(s, pick);  // planes copied in parallel
    EXPECT_EQ(some.sample_type(), s.sample_type());
    ASSERT_EQ(some.num_images(), int(pick.size()));
    for (size_t k = 0; k < pick.size(); ++k) {
      EXPECT_EQ(some.lights()[k].direction, s.lights()[size_t(pick[k])].direction);
      for (int c = 0; c < s.channels(); ++c)
        for (int64_t p = 0; p < s.plane_size(); ++p)
          ASSERT_EQ(some.Sample(int(k), c, p), s.Sample(pick[k], c, p))
              << k << " " << c << " " << p;
    }
  }
}

// Held-out figures on an integer stack equal those on the same stack as float32, the 8-bit sRGB
// ones included (their raw codes come from a table of the stored codes, not from the floats).
// 40² texels: two runs of kEvalRun (1024), so the second starts inside the planes; RGB and grey.
TEST(NativeDepth, HeldOutFiguresEqualFloat) {
  const LightStack rgb = SynthData({"plastic", "dome:40", 40, 0.01}).stack;
  LightStack grey(rgb.width(), rgb.height(), 1, rgb.num_images());
  grey.lights() = rgb.lights();
  for (int i = 0; i < grey.num_images(); ++i)
    for (int64_t p = 0; p < grey.plane_size(); ++p) grey.Plane(i, 0)[p] = rgb.Sample(i, 1, p);
  const LightStack* stacks[] = {&rgb, &grey};
  for (const LightStack* f : stacks)
    for (int bits : {8, 16}) {
      const LightStack q = QuantiseStack(*f, bits);
      const LightStack qf = q.ToFloat();
      for (const char* name : {"lambert", "ptm"}) {
        const std::string what = std::string(name) + ", " + std::to_string(f->channels()) +
                                 " channel(s), " + std::to_string(bits) + " bits";
        auto method = MakeMethod(name);
        ASSERT_TRUE(method) << name;
        auto a = HeldOut(*method, q, 4, {}), b = HeldOut(*method, qf, 4, {});
        ASSERT_TRUE(a.ok() && b.ok()) << what;
        EXPECT_EQ(a->samples, b->samples) << what;
        EXPECT_EQ(a->rmse, b->rmse) << what;
        EXPECT_EQ(a->rmse_srgb8, b->rmse_srgb8) << what;
        EXPECT_EQ(a->rmse_srgb8_common, b->rmse_srgb8_common) << what;
        EXPECT_GT(a->rmse_srgb8, 0.1) << what;  // a glossy material: the codes do differ
      }
    }
}

// BorrowImages: a view reads the source's planes in its own image order (views of views too),
// carries the same description as SelectImages' copy, and copies its images before any write,
// leaving the source as it was.
TEST(Borrow, ViewsReadTheSourcesSamplesAndWritesCopyThemFirst) {
  const LightStack f = SynthData({"plaster", "dome:12", 9}).stack;
  const std::vector<int> pick = {3, 1, 7, 11, 0, 5}, again = {4, 0, 2};
  for (const LightStack& s : {QuantiseStack(f, 8), QuantiseStack(f, 16), f}) {
    SCOPED_TRACE(int(s.sample_type()));
    const LightStack copy = SelectImages(s, pick), view = BorrowImages(s, pick);
    EXPECT_TRUE(view.is_view());
    EXPECT_FALSE(copy.is_view());
    EXPECT_EQ(view.MemoryBytes(), s.lut().size() * sizeof(float)) << "a view holds no sample";
    ASSERT_EQ(view.num_images(), copy.num_images());
    EXPECT_EQ(view.sample_type(), s.sample_type());
    EXPECT_EQ(view.image_files, copy.image_files);
    EXPECT_EQ(view.encodings.size(), copy.encodings.size());
    const LightStack view2 = BorrowImages(view, again);  // images pick[again[k]] of s
    std::vector<float> a(size_t(s.plane_size())), b(a.size());
    for (int k = 0; k < view.num_images(); ++k) {
      EXPECT_EQ(view.lights()[size_t(k)].direction, copy.lights()[size_t(k)].direction);
      for (int c = 0; c < s.channels(); ++c) {
        const int n = int(s.plane_size());
        const float* x = view.Texels(k, c, 0, n, a.data());
        const float* y = copy.Texels(k, c, 0, n, b.data());
        for (int p = 0; p < n; ++p) ASSERT_EQ(x[p], y[p]) << k << " " << c << " " << p;
        EXPECT_EQ(view.At(k, c, 8, 3), s.At(pick[size_t(k)], c, 8, 3));
      }
    }
    for (int k = 0; k < view2.num_images(); ++k)
      for (int64_t p = 0; p < s.plane_size(); ++p)
        ASSERT_EQ(view2.Sample(k, 2, p), s.Sample(pick[size_t(again[size_t(k)])], 2, p));
    // Writing a view (its copy) makes it own its images; the source is unchanged.
    LightStack w = view2;
    EXPECT_TRUE(w.is_view());
    const float before = s.Sample(pick[size_t(again[1])], 1, 5);
    if (s.is_float())
      w.Plane(1, 1)[5] = 0.25f;
    else if (s.sample_type() == SampleType::kUint8)
      w.Codes<uint8_t>(1, 1)[5] = 200;
    else
      w.Codes<uint16_t>(1, 1)[5] = 60000;
    EXPECT_FALSE(w.is_view());
    EXPECT_GT(w.MemoryBytes(), s.lut().size() * sizeof(float));
    EXPECT_EQ(s.Sample(pick[size_t(again[1])], 1, 5), before);
    EXPECT_EQ(view2.Sample(1, 1, 5), before);
    EXPECT_NE(w.Sample(1, 1, 5), before);
    for (int k = 0; k < w.num_images(); ++k)
      for (int c = 0; c < s.channels(); ++c)
        for (int64_t p = 0; p < s.plane_size(); ++p)
          if (k != 1 || c != 1 || p != 5) {
            ASSERT_EQ(w.Sample(k, c, p), view2.Sample(k, c, p));
          }
    if (s.is_float()) {
      const LightStack owned = view.ToFloat();  // a float view's ToFloat owns its samples
      EXPECT_FALSE(owned.is_view());
      EXPECT_EQ(owned.data()[s.plane_size() * 3 + 7], s.Sample(pick[1], 0, 7));
      GTEST_FLAG_SET(death_test_style, "threadsafe");
      EXPECT_DEATH((void)view.data(), "on a view");
    }
    LightStack r = view;
    r.ReleaseSamples();
    EXPECT_FALSE(r.is_view());
    EXPECT_TRUE(view.is_view());
  }
}

// Every method fits a view of some images exactly as it fits a copy of them (held-out folds and
// model selection fit views), on an 8-bit and a float stack with clipped samples and a mask.
TEST(Borrow, EveryMethodFitsAViewAsItFitsACopy) {
  auto data = SynthData({"plastic", "dome:30", 23, 0.01});
  for (int i = 0; i < data.stack.num_images(); ++i)
    for (int c = 0; c < 3; ++c)
      for (float& v : data.stack.Plane(i, c)) v = std::min(v * 1.6f, 1.0f);
  LightStack q8 = QuantiseStack(data.stack, 8), qf = data.stack;
  for (LightStack* q : {&q8, &qf}) {
    q->mask.assign(size_t(q->plane_size()), 1);
    for (int64_t p = 0; p < q->plane_size(); p += 7) q->mask[size_t(p)] = 0;
  }
  std::vector<int> train;
  for (int i = 0; i < q8.num_images(); ++i)
    if (i % 4 != 1) train.push_back(i);
  int fitted = 0;
  for (const LightStack* q : {&q8, &qf})
    for (const std::string& name : MethodNames()) {
      const LightStack copy = SelectImages(*q, train), view = BorrowImages(*q, train);
      auto method = MakeMethod(name);
      ASSERT_TRUE(method) << name;
      auto a = method->Fit(view, {}), b = method->Fit(copy, {});
      ASSERT_EQ(a.ok(), b.ok()) << name;
      if (!b.ok()) {
        EXPECT_EQ(a.status().message(), b.status().message()) << name;
        continue;
      }
      ++fitted;
      EXPECT_EQ(a->status, b->status) << name;
      ExpectSameMaps(a->maps, b->maps, name);
      const auto ra = Reconstruction(*q, a->maps, a->status);
      const auto rb = Reconstruction(*q, b->maps, b->status);
      EXPECT_EQ(ra.rmse, rb.rmse) << name;
    }
  EXPECT_GE(fitted, 24);
}

}  // namespace
}  // namespace matfit::fit
