#include "core/light_stack.h"

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <type_traits>
#include <utility>

#include "core/parallel.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

namespace matfit {
namespace {

// out[x] = lut[src[x]]: one table lookup per sample. Codes are read 8 bytes at a time and split
// with shifts, which halves the load traffic of a byte-by-byte loop (≈ 0.35 ns per 8-bit sample
// on the 2-core test machine, against 0.6 byte by byte and 0.45–0.6 with AVX2/AVX-512 gathers).
void DecodeRun(const uint8_t* src, int n, const float* __restrict lut, float* __restrict out) {
  int x = 0;
  for (; x + 8 <= n; x += 8) {
    uint64_t b;
    std::memcpy(&b, src + x, sizeof b);
    // Written out: GCC at -O2 keeps the k loop, which runs at half this speed.
    float* o = out + x;
    o[0] = lut[b & 0xff], o[1] = lut[(b >> 8) & 0xff], o[2] = lut[(b >> 16) & 0xff];
    o[3] = lut[(b >> 24) & 0xff], o[4] = lut[(b >> 32) & 0xff], o[5] = lut[(b >> 40) & 0xff];
    o[6] = lut[(b >> 48) & 0xff], o[7] = lut[b >> 56];
  }
  for (; x < n; ++x) out[x] = lut[src[x]];
}

#if defined(__x86_64__) && defined(__GNUC__)
// The same lookup 64 codes at a time with AVX-512 VBMI: each byte of the 256 floats is a 256-byte
// table (lut_bytes[q · 256 + code] = byte q of lut[code]), looked up by two 128-entry byte
// permutes and a blend on the code's top bit; the four byte planes are then interleaved into
// floats (bytes → words → dwords within 128-bit lanes, then the lanes transposed). Every bit of
// every float is the table's (NaN payloads and −0 included). ≈ 0.12 ns a sample on runs of 512+
// on the 2-core test machine, 0.23 on runs of 64, against 0.44 for DecodeRun above.
// (GCC 12's _mm512_shuffle_i64x2 passes _mm512_undefined_epi32() as its unused merge source, which
// -Wmaybe-uninitialized reports when inlined; clang has no such warning.)
#if !defined(__clang__)
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
__attribute__((target("avx512f,avx512bw,avx512vbmi"))) void DecodeRunVbmi(const uint8_t* src, int n,
                                                                          const uint8_t* lut_bytes,
                                                                          const float* lut,
                                                                          float* out) {
  __m512i t[4][4];
  for (int q = 0; q < 4; ++q)
    for (int h = 0; h < 4; ++h) t[q][h] = _mm512_loadu_si512(lut_bytes + 256 * q + 64 * h);
  int x = 0;
  for (; x + 64 <= n; x += 64) {
    const __m512i c = _mm512_loadu_si512(src + x);
    const __mmask64 upper = _mm512_movepi8_mask(c);  // codes 128 … 255
    __m512i b[4];
    for (int q = 0; q < 4; ++q)
      b[q] = _mm512_mask_blend_epi8(upper, _mm512_permutex2var_epi8(t[q][0], c, t[q][1]),
                                    _mm512_permutex2var_epi8(t[q][2], c, t[q][3]));
    const __m512i w01l = _mm512_unpacklo_epi8(b[0], b[1]), w01h = _mm512_unpackhi_epi8(b[0], b[1]);
    const __m512i w23l = _mm512_unpacklo_epi8(b[2], b[3]), w23h = _mm512_unpackhi_epi8(b[2], b[3]);
    // f_i: in 128-bit lane L, the floats of codes 16 L + 4 i … 16 L + 4 i + 3.
    const __m512i f0 = _mm512_unpacklo_epi16(w01l, w23l), f1 = _mm512_unpackhi_epi16(w01l, w23l);
    const __m512i f2 = _mm512_unpacklo_epi16(w01h, w23h), f3 = _mm512_unpackhi_epi16(w01h, w23h);
    const __m512i t0 = _mm512_shuffle_i64x2(f0, f1, 0x44), t1 = _mm512_shuffle_i64x2(f0, f1, 0xee);
    const __m512i t2 = _mm512_shuffle_i64x2(f2, f3, 0x44), t3 = _mm512_shuffle_i64x2(f2, f3, 0xee);
    _mm512_storeu_si512(out + x, _mm512_shuffle_i64x2(t0, t2, 0x88));
    _mm512_storeu_si512(out + x + 16, _mm512_shuffle_i64x2(t0, t2, 0xdd));
    _mm512_storeu_si512(out + x + 32, _mm512_shuffle_i64x2(t1, t3, 0x88));
    _mm512_storeu_si512(out + x + 48, _mm512_shuffle_i64x2(t1, t3, 0xdd));
  }
  DecodeRun(src + x, n - x, lut, out + x);
}
#if !defined(__clang__)
#pragma GCC diagnostic pop
#endif

// Whether the CPU runs DecodeRunVbmi; MATFIT_KERNELS=generic or =avx2 turns it off, as it caps
// the fit's row kernels (fit/row_kernels.h; the tests run both decodes).
bool HasVbmi() {
  static const bool has = [] {
    const char* cap = std::getenv("MATFIT_KERNELS");
    if (cap && (std::strcmp(cap, "generic") == 0 || std::strcmp(cap, "avx2") == 0)) return false;
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512bw") &&
           __builtin_cpu_supports("avx512vbmi");
  }();
  return has;
}
#endif

void DecodeRun(const uint16_t* src, int n, const float* __restrict lut, float* __restrict out) {
  int x = 0;
  for (; x + 4 <= n; x += 4) {
    uint64_t b;
    std::memcpy(&b, src + x, sizeof b);
    float* o = out + x;
    o[0] = lut[b & 0xffff], o[1] = lut[(b >> 16) & 0xffff], o[2] = lut[(b >> 32) & 0xffff];
    o[3] = lut[b >> 48];
  }
  for (; x < n; ++x) out[x] = lut[src[x]];
}

}  // namespace

LightStack::LightStack(int width, int height, int channels, int num_images)
    : LightStack(width, height, channels, num_images, SampleType::kFloat32, {}) {}

LightStack::LightStack(int width, int height, int channels, int num_images, SampleType type,
                       std::vector<float> lut)
    : LightStack(width, height, channels, num_images, type, std::move(lut), Uninitialised{}) {
  std::fill(f32_.begin(), f32_.end(), 0.0f);
  std::fill(u8_.begin(), u8_.end(), uint8_t(0));
  std::fill(u16_.begin(), u16_.end(), uint16_t(0));
}

LightStack::LightStack(int width, int height, int channels, int num_images, SampleType type,
                       std::vector<float> lut, Uninitialised)
    : width_(width),
      height_(height),
      channels_(channels),
      num_images_(num_images),
      type_(type),
      lut_(std::move(lut)) {
  MATFIT_CHECK(width >= 0 && height >= 0 && num_images >= 0);
  MATFIT_CHECK(channels == 1 || channels == 3, "stacks hold 1 or 3 channels");
  MATFIT_CHECK(lut_.size() == size_t(SampleCodes(type)),
               "an integer stack needs one table entry per code, a float stack none");
  IndexLut();
  const size_t samples = size_t(plane_size()) * channels * num_images;
  switch (type) {  // default-initialised (LargePageAllocator): no value written yet
    case SampleType::kFloat32: f32_.resize(samples); break;
    case SampleType::kUint8: u8_.resize(samples); break;
    case SampleType::kUint16: u16_.resize(samples); break;
  }
  lights_.resize(num_images);
}

template <typename T>
std::span<const T> LightStack::Codes(int image, int channel) const {
  MATFIT_CHECK(!released_, "LightStack::Codes after ReleaseSamples()");
  if constexpr (std::is_same_v<T, uint8_t>) {
    MATFIT_CHECK(type_ == SampleType::kUint8, "Codes<uint8_t> on a stack that is not uint8");
    return {U8() + PlaneOffset(image, channel), size_t(plane_size())};
  } else {
    static_assert(std::is_same_v<T, uint16_t>, "codes are uint8_t or uint16_t");
    MATFIT_CHECK(type_ == SampleType::kUint16, "Codes<uint16_t> on a stack that is not uint16");
    return {U16() + PlaneOffset(image, channel), size_t(plane_size())};
  }
}

template <typename T>
std::span<T> LightStack::Codes(int image, int channel) {
  Own();
  const std::span<const T> codes = std::as_const(*this).Codes<T>(image, channel);
  // The caller may write codes. Only a stack with a probe is written to here: writers that
  // fill fresh stacks from several threads (SelectImages, crops) only read the null pointer.
  if (probe) probe.reset();
  return {const_cast<T*>(codes.data()), codes.size()};
}

template std::span<uint8_t> LightStack::Codes<uint8_t>(int, int);
template std::span<uint16_t> LightStack::Codes<uint16_t>(int, int);
template std::span<const uint8_t> LightStack::Codes<uint8_t>(int, int) const;
template std::span<const uint16_t> LightStack::Codes<uint16_t>(int, int) const;

void LightStack::Decode(int64_t k, int n, float* out) const {
#if defined(__x86_64__) && defined(__GNUC__)
  if (type_ == SampleType::kUint8 && n >= 64 && !lut_bytes_.empty() && HasVbmi())
    return DecodeRunVbmi(U8() + k, n, lut_bytes_.data(), lut_.data(), out);
#endif
  if (type_ == SampleType::kUint8)
    DecodeRun(U8() + k, n, lut_.data(), out);
  else
    DecodeRun(U16() + k, n, lut_.data(), out);
}

void LightStack::Own() {
  if (!borrowed_) return;
  MATFIT_CHECK(!released_);
  LightStack own(width_, height_, channels_, num_images_, type_, lut_, Uninitialised{});
  const int64_t P = plane_size();
  ParallelFor(0, int64_t(num_images_) * channels_, [&](int64_t b, int64_t e) {
    for (int64_t j = b; j < e; ++j) {
      const int64_t from = PlaneOffset(int(j / channels_), int(j % channels_)), to = j * P;
      switch (type_) {
        case SampleType::kFloat32: std::copy_n(F32() + from, P, own.f32_.data() + to); break;
        case SampleType::kUint8: std::copy_n(U8() + from, P, own.u8_.data() + to); break;
        case SampleType::kUint16: std::copy_n(U16() + from, P, own.u16_.data() + to); break;
      }
    }
  });
  f32_.swap(own.f32_), u8_.swap(own.u8_), u16_.swap(own.u16_);
  borrowed_ = nullptr;
  borrowed_images_.clear();
}

LightStack LightStack::ToFloat() const {
  MATFIT_CHECK(!released_, "LightStack::ToFloat after ReleaseSamples()");
  if (is_float()) {
    LightStack copy = *this;
    copy.Own();
    return copy;
  }
  LightStack out(width_, height_, channels_, num_images_);
  for (int i = 0; i < num_images_; ++i)
    for (int c = 0; c < channels_; ++c)
      Decode(PlaneOffset(i, c), int(plane_size()), out.Plane(i, c).data());
  out.lights_ = lights_;
  out.view_direction = view_direction;
  out.view_theta_deg = view_theta_deg, out.view_phi_deg = view_phi_deg;
  out.mask = mask;
  out.mm_per_texel = mm_per_texel;
  out.near_frame = near_frame;
  out.band = band;
  out.layout = layout, out.source = source, out.object_name = object_name;
  out.image_files = image_files;
  out.encodings = encodings, out.encoding_reasons = encoding_reasons;
  out.saturated_pixels = saturated_pixels, out.nonfinite_samples = nonfinite_samples;
  return out;
}

int64_t LightStack::MaskedTexels() const {
  if (mask.empty()) return plane_size();
  return std::count_if(mask.begin(), mask.end(), [](uint8_t m) { return m != 0; });
}

void LightStack::IndexLut() {
  lut_bytes_.clear();
  if (type_ != SampleType::kUint8) return;
  lut_bytes_.resize(4 * 256);
  for (int code = 0; code < 256; ++code) {
    uint32_t bits;
    std::memcpy(&bits, &lut_[size_t(code)], sizeof bits);
    for (int q = 0; q < 4; ++q) lut_bytes_[size_t(256 * q + code)] = uint8_t(bits >> (8 * q));
  }
}

void LightStack::Relinearise(const ColorEncoding& enc, const std::string& reason) {
  MATFIT_CHECK(!is_float(), "LightStack::Relinearise: a float stack has no codes to re-decode");
  lut_ = LinearDecodeTable(enc, type_ == SampleType::kUint8 ? 8 : 16);
  IndexLut();
  encodings.assign(size_t(num_images_), enc);
  encoding_reasons.assign(size_t(num_images_), reason);
}

void LightStack::ReleaseSamples() {
  // swap: clear() keeps the capacity; the pages go back to the system here.
  decltype(f32_)().swap(f32_);
  decltype(u8_)().swap(u8_);
  decltype(u16_)().swap(u16_);
  borrowed_ = nullptr;
  borrowed_images_.clear();
  probe.reset();
  released_ = true;
}

size_t LightStack::MemoryBytes() const {
  return f32_.size() * sizeof(float) + u8_.size() + u16_.size() * sizeof(uint16_t) +
         lut_.size() * sizeof(float) + mask.size();
}

LightSample LightFromDirection(const Vec3& d) {
  LightSample s;
  s.direction = Normalize(d);
  AnglesDegFromDirection(s.direction, &s.theta_deg, &s.phi_deg);
  return s;
}

bool LightStack::is_multi_view() const {
  for (int i = 1; i < int(lights_.size()); ++i)
    if (Length(ViewOf(i) - ViewOf(0)) > 1e-9) return true;
  return false;
}

std::vector<std::vector<int>> ViewGroups(const LightStack& s) {
  std::vector<std::vector<int>> groups;
  std::vector<Vec3> views;
  for (int i = 0; i < int(s.lights().size()); ++i) {  // a headers-only stack has lights only
    const Vec3 v = s.ViewOf(i);
    size_t g = 0;
    while (g < views.size() && Length(views[g] - v) > 1e-9) ++g;
    if (g == views.size()) views.push_back(v), groups.emplace_back();
    groups[g].push_back(i);
  }
  return groups;
}

int MostFrontalView(const LightStack& s, const std::vector<std::vector<int>>& groups) {
  int best = 0;
  for (size_t g = 1; g < groups.size(); ++g)
    if (s.ViewOf(groups[g][0]).z > s.ViewOf(groups[size_t(best)][0]).z) best = int(g);
  return best;
}

LightStack SelectView(const LightStack& s, const std::vector<int>& group) {
  LightStack out = SelectImages(s, group);
  if (group.empty()) return out;
  out.view_direction = s.ViewOf(group[0]);
  const LightSample& l = s.lights()[size_t(group[0])];
  if (l.has_view)
    out.view_theta_deg = l.view_theta_deg, out.view_phi_deg = l.view_phi_deg;
  else
    out.view_theta_deg = s.view_theta_deg, out.view_phi_deg = s.view_phi_deg;
  return out;
}

namespace {

// Everything of `s` but the samples, for images `idx`: lights, view, mask, physical size,
// frame, band and per-image provenance (SelectImages, BorrowImages).
void CopyDescription(const LightStack& s, const std::vector<int>& idx, LightStack* out) {
  auto pick = [&](const auto& v, auto& dst) {
    if (v.size() == size_t(s.num_images()))
      for (int i : idx) dst.push_back(v[size_t(i)]);
  };
  for (size_t k = 0; k < idx.size(); ++k) out->lights()[k] = s.lights()[size_t(idx[k])];
  out->view_direction = s.view_direction;
  out->view_theta_deg = s.view_theta_deg, out->view_phi_deg = s.view_phi_deg;
  out->mask = s.mask;
  out->mm_per_texel = s.mm_per_texel;
  out->near_frame = s.near_frame;
  out->band = s.band;
  out->layout = s.layout, out->source = s.source, out->object_name = s.object_name;
  pick(s.image_files, out->image_files);
  pick(s.encodings, out->encodings);
  pick(s.encoding_reasons, out->encoding_reasons);
  pick(s.saturated_pixels, out->saturated_pixels);
  pick(s.nonfinite_samples, out->nonfinite_samples);
}

}  // namespace

LightStack BorrowImages(const LightStack& s, const std::vector<int>& idx) {
  for (int i : idx) MATFIT_CHECK(i >= 0 && i < s.num_images());
  MATFIT_CHECK(!s.samples_released(), "BorrowImages: the stack's samples were released");
  LightStack out(s.width(), s.height(), s.channels(), 0, s.sample_type(), s.lut(),
                 LightStack::Uninitialised{});
  out.num_images_ = int(idx.size());
  out.lights_.resize(idx.size());
  // A view of a view reads the first source's planes.
  const void* first = s.sample_type() == SampleType::kFloat32 ? static_cast<const void*>(s.F32())
                      : s.sample_type() == SampleType::kUint8 ? static_cast<const void*>(s.U8())
                                                              : static_cast<const void*>(s.U16());
  out.borrowed_ = first;
  for (int i : idx) out.borrowed_images_.push_back(s.borrowed_ ? s.borrowed_images_[size_t(i)] : i);
  CopyDescription(s, idx, &out);
  return out;
}

LightStack SelectImages(const LightStack& s, const std::vector<int>& idx) {
  for (int i : idx) MATFIT_CHECK(i >= 0 && i < s.num_images());
  // Every plane is copied below: no zeroing first, and the copies run in parallel (a held-out
  // fold of 512×344×240 8-bit takes 91 MB; zeroed and copied by one thread it was a serial
  // 0.03–0.06 s per fold).
  LightStack out(s.width(), s.height(), s.channels(), int(idx.size()), s.sample_type(), s.lut(),
                 LightStack::Uninitialised{});
  const int C = s.channels();
  ParallelFor(0, int64_t(idx.size()) * C, [&](int64_t b, int64_t e) {
    for (int64_t j = b; j < e; ++j) {
      const int k = int(j / C), c = int(j % C), i = idx[size_t(k)];
      auto copy = [&](auto src, auto dst) { std::copy(src.begin(), src.end(), dst.begin()); };
      switch (s.sample_type()) {
        case SampleType::kFloat32: copy(s.Plane(i, c), out.Plane(k, c)); break;
        case SampleType::kUint8: copy(s.Codes<uint8_t>(i, c), out.Codes<uint8_t>(k, c)); break;
        case SampleType::kUint16: copy(s.Codes<uint16_t>(i, c), out.Codes<uint16_t>(k, c)); break;
      }
    }
  });
  CopyDescription(s, idx, &out);
  return out;
}

}  // namespace matfit
