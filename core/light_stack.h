// LightStack: N images of one sample under N lights, linear, at the files' native depth.
//
// Layout (plane-major SoA): sample[((i * C + c) * H + y) * W + x] for image i, channel c,
// row y (0 = top), column x. Samples are float32 (float inputs, stacks built in memory) or the
// files' own uint8 / uint16 codes; an integer stack carries a table lut[code] = linear value,
// built with the transfer function the decoder used, so every read gives the value a float
// decode would (bit for bit). Kernels read through Row()/Texels() (a pointer into the planes
// for float stacks, decoded into caller scratch otherwise). Directions are unit vectors in the
// sample's tangent frame (METHODS.md §0: z = surface normal toward the camera, x = image right,
// y = image up), pointing away from the surface.
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "core/check.h"
#include "core/color.h"
#include "core/large_page_allocator.h"
#include "core/sample_type.h"
#include "core/vec3.h"

namespace matfit {

class Comm;
struct StackProbe;  // core/stack_probe.h

// A stack split into row bands across the ranks of a distributed fit (docs/scale-out.md): this
// process holds rows [row0, row0 + height()) of a stack of full_height rows. Stack-wide figures
// (sums, medians, sampled grids) reduce over `comm` (core/stack_band.h). comm null: the stack is
// whole (every single-process run).
struct StackBand {
  const Comm* comm = nullptr;
  int row0 = 0;
  int full_height = 0;  // 0: the stack's own height
};

struct LightSample {
  Vec3 direction{0, 0, 1};            // unit, toward the light
  Vec3 intensity{1, 1, 1};            // relative RGB intensity (1 = nominal)
  double theta_deg = 0, phi_deg = 0;  // direction as parsed or derived (METHODS.md §0)
  // A near (point) light: its position in the stack's NearFrame. `direction` and `intensity`
  // are then as seen from the frame's origin (the image centre); core/near_lights.h gives them
  // at any texel (direction to the light, intensity falling off as 1/r²).
  bool has_position = false;
  Vec3 position{0, 0, 0};
  // Multi-view stacks (every view of a BTF, docs/formats.md): this image's camera direction
  // (unit, toward the camera, tangent frame) and its angles. has_view false: the stack's
  // view_direction, as in every single-view stack.
  bool has_view = false;
  Vec3 view{0, 0, 1};
  double view_theta_deg = 0, view_phi_deg = 0;
};

// Where the stack's texels lie in the frame of the lights' positions (docs/formats.md,
// "light_positions.txt"): texel (x, y) (column, row) at (x0 + x·step, y0 − y·step, 0); x right,
// y up, z toward the camera, origin at the centre of the images as read, one unit per source
// pixel. Crops and mips keep it (core/stack_ops.h).
struct NearFrame {
  double x0 = 0, y0 = 0, step = 1;
};

// A unit-intensity light along `direction` (normalised), its angles derived from it.
LightSample LightFromDirection(const Vec3& direction);

class LightStack {
 public:
  LightStack() = default;
  // Allocates zeroed float32 planes; lights are default (frontal, unit intensity).
  LightStack(int width, int height, int channels, int num_images);
  // Zeroed planes of `type`; integer types need `lut` with SampleCodes(type) entries
  // (code → linear value), float32 an empty one.
  LightStack(int width, int height, int channels, int num_images, SampleType type,
             std::vector<float> lut);
  // The same without zeroing: for a producer that writes every sample (the dataset loader), so
  // the stack's pages are first touched by the threads that decode into them, not by one memset.
  struct Uninitialised {};
  LightStack(int width, int height, int channels, int num_images, SampleType type,
             std::vector<float> lut, Uninitialised);

  int width() const { return width_; }
  int height() const { return height_; }
  int channels() const { return channels_; }
  int num_images() const { return num_images_; }
  int64_t plane_size() const { return int64_t(width_) * height_; }
  int64_t texels() const { return plane_size(); }
  // The whole stack's rows and texels when this is one band of it (else height(), plane_size()).
  int full_height() const { return band.full_height > 0 ? band.full_height : height_; }
  int64_t full_plane_size() const { return int64_t(width_) * full_height(); }
  bool is_band() const { return band.comm != nullptr; }
  SampleType sample_type() const { return type_; }
  bool is_float() const { return type_ == SampleType::kFloat32; }
  // Code → linear value (256 or 65536 entries); empty for float stacks.
  const std::vector<float>& lut() const { return lut_; }

  // Float stacks only (a MATFIT_CHECK failure on a native-depth stack): the planes for code
  // that builds or edits stacks (renderer, perturbations, tests), and the planes as one array.
  // Readers use Row/Texels/At/Sample, which work on every stack.
  // On a view (BorrowImages) the non-const accessors (Plane, data, Codes) first copy the
  // view's images into samples of its own (Own): writing never reaches the source.
  std::span<float> Plane(int image, int channel) {
    CheckFloat();
    Own();
    return {f32_.data() + PlaneOffset(image, channel), size_t(plane_size())};
  }
  std::span<const float> Plane(int image, int channel) const {
    CheckFloat();
    return {F32() + PlaneOffset(image, channel), size_t(plane_size())};
  }
  // Linear value of one sample, any sample type (read-only for every stack, so that reading a
  // non-const native stack never picks a float-only overload; write through Plane()).
  float At(int image, int channel, int y, int x) const {
    MATFIT_DCHECK(y >= 0 && y < height_ && x >= 0 && x < width_);
    return Sample(image, channel, int64_t(y) * width_ + x);
  }
  // Linear value of texel p (row-major index) of (image, channel), any sample type.
  float Sample(int image, int channel, int64_t p) const {
    MATFIT_DCHECK(p >= 0 && p < plane_size());
    const int64_t k = PlaneOffset(image, channel) + p;
    if (type_ == SampleType::kFloat32) return F32()[k];
    return type_ == SampleType::kUint8 ? lut_[U8()[k]] : lut_[U16()[k]];
  }
  // Row y, columns [x0, x0 + n) of (image, channel) as linear floats. Kernels read the stack
  // through this: it points into the planes for float stacks, and decodes into `scratch`
  // (n floats, caller-owned) for stacks held at their native depth.
  const float* Row(int image, int channel, int y, int x0, int n, float* scratch) const {
    MATFIT_DCHECK(y >= 0 && y < height_ && x0 >= 0 && x0 + n <= width_);
    return Texels(image, channel, int64_t(y) * width_ + x0, n, scratch);
  }
  // The same for a run of n texels starting at row-major texel index p (may span rows).
  const float* Texels(int image, int channel, int64_t p, int n, float* scratch) const {
    MATFIT_DCHECK(p >= 0 && p + n <= plane_size());
    const int64_t k = PlaneOffset(image, channel) + p;
    if (type_ == SampleType::kFloat32) return F32() + k;
    Decode(k, n, scratch);
    return scratch;
  }
  // Asks the cache for texels [p, p + n) of (image, channel) ahead of a read (a gather across
  // planes, which the hardware prefetcher cannot predict).
  void Prefetch(int image, int channel, int64_t p, int n) const {
    const int64_t k = PlaneOffset(image, channel) + p;
    const char* b = type_ == SampleType::kFloat32 ? reinterpret_cast<const char*>(F32() + k)
                    : type_ == SampleType::kUint8 ? reinterpret_cast<const char*>(U8() + k)
                                                  : reinterpret_cast<const char*>(U16() + k);
    const int64_t bytes = int64_t(n) * (type_ == SampleType::kFloat32 ? 4
                                        : type_ == SampleType::kUint8 ? 1
                                                                      : 2);
    for (int64_t o = 0; o < bytes; o += 64) __builtin_prefetch(b + o);
  }
  // The stored codes of (image, channel) of an integer stack; T must match sample_type()
  // (uint8_t or uint16_t). For readers that store codes and writers that keep them.
  template <typename T>
  std::span<T> Codes(int image, int channel);
  template <typename T>
  std::span<const T> Codes(int image, int channel) const;
  // Float stacks only: every sample, plane after plane (a view's planes are its source's, in
  // the source's order: const data() refuses a view).
  const float* data() const {
    CheckFloat();
    MATFIT_CHECK(!is_view(), "LightStack::data() on a view: read it plane by plane");
    return f32_.data();
  }
  float* data() {
    CheckFloat();
    Own();
    return f32_.data();
  }
  // The same stack as float32 (a copy that owns its samples, also of a view; metadata kept).
  // Costs 4 bytes per sample.
  LightStack ToFloat() const;
  // Integer stacks only: linearises the stored codes with `enc` from now on (a new code table,
  // no sample touched), recorded for every image with `reason`.
  void Relinearise(const ColorEncoding& enc, const std::string& reason);

  std::vector<LightSample>& lights() { return lights_; }
  const std::vector<LightSample>& lights() const { return lights_; }

  // View direction (unit, tangent frame); frontal (0,0,1) for rectified BTF views. In a
  // multi-view stack the images carry their own (LightSample::view) and this is the reference
  // (most frontal) view.
  Vec3 view_direction{0, 0, 1};
  double view_theta_deg = 0, view_phi_deg = 0;
  // Image i's view: lights()[i].view when it has one, else view_direction.
  Vec3 ViewOf(int image) const {
    const LightSample& l = lights_[size_t(image)];
    return l.has_view ? l.view : view_direction;
  }
  // Whether the images were taken from more than one view (some image carries its own view
  // that differs from another's).
  bool is_multi_view() const;
  // Optional validity mask (1 = sample texel), plane_size() bytes; empty = every texel valid.
  std::vector<uint8_t> mask;
  // Physical size of one texel in millimetres; 0 = unknown.
  double mm_per_texel = 0;
  // Near lights: where the texels lie among the lights' positions (used when they have one).
  NearFrame near_frame;
  bool has_light_positions() const { return !lights_.empty() && lights_[0].has_position; }

  // Provenance, filled by readers: layout name, source folder, one file per image.
  std::string layout, source, object_name;
  std::vector<std::string> image_files;
  // How the files were linearised (one entry per image) and what decoding noticed.
  std::vector<ColorEncoding> encodings;
  std::vector<std::string> encoding_reasons;
  std::vector<int64_t> saturated_pixels;   // per image, integer formats only
  std::vector<int64_t> nonfinite_samples;  // per image, float formats only
  // What a reader noticed but did not refuse (coded, core/warnings.h): ComputeDatasetInfo
  // reports them with its own.
  std::vector<std::string> read_warnings;

  // Where the mask came from ("mask.png", "alpha channel of 81 images"); empty: no mask. When
  // the images' alpha is opaque everywhere there is no mask and this says so.
  std::string mask_source;
  // The images' own size in their files (0 × 0 for stacks not read from files) and the region
  // read from them with --crop (crop_w 0: the whole images). Kept through mips and crops made
  // later (stack_ops.h), so a stack is the crop itself only while it has the crop's size.
  int source_width = 0, source_height = 0;
  int crop_x = 0, crop_y = 0, crop_w = 0, crop_h = 0;
  bool is_read_crop() const { return crop_w > 0 && width() == crop_w && full_height() == crop_h; }

  bool has_mask() const { return !mask.empty(); }
  // An integer stack's codes at the diagnosis's texels, taken by the loader while it decoded
  // the images (core/stack_probe.h); null otherwise. Dropped by the non-const Codes() (the
  // codes may change; call it from one thread, or drop the probe first) and by ReleaseSamples.
  std::shared_ptr<const StackProbe> probe;
  StackBand band;  // which rows of a distributed stack these are (default: the whole stack)
  int64_t MaskedTexels() const;  // texels inside the mask (all when no mask)
  // Bytes held by the samples (at their native size; none for a view's borrowed ones), the
  // lookup table and the mask.
  size_t MemoryBytes() const;
  // Frees the samples and keeps everything else (size, lights, mask, metadata): for a job whose
  // remaining steps need only the stack's description (fit/fit_job.cc, before the pack is
  // written). Reading a sample afterwards is a MATFIT_DCHECK failure.
  void ReleaseSamples();
  bool samples_released() const { return released_; }
  // Whether the samples are another stack's (BorrowImages).
  bool is_view() const { return borrowed_ != nullptr; }

 private:
  int64_t PlaneOffset(int image, int channel) const {
    MATFIT_DCHECK(image >= 0 && image < num_images_ && channel >= 0 && channel < channels_);
    MATFIT_DCHECK(!released_, "LightStack: a sample read after ReleaseSamples()");
    const int64_t source = borrowed_ ? borrowed_images_[size_t(image)] : image;
    return (source * channels_ + channel) * plane_size();
  }
  // The first sample of the planes PlaneOffset indexes: the stack's own, or a view's source's.
  const float* F32() const {
    return borrowed_ ? static_cast<const float*>(borrowed_) : f32_.data();
  }
  const uint8_t* U8() const {
    return borrowed_ ? static_cast<const uint8_t*>(borrowed_) : u8_.data();
  }
  const uint16_t* U16() const {
    return borrowed_ ? static_cast<const uint16_t*>(borrowed_) : u16_.data();
  }
  // A view takes samples of its own: a copy of its images, in its order (no-op otherwise).
  void Own();
  friend LightStack BorrowImages(const LightStack& stack, const std::vector<int>& indices);

  void CheckFloat() const {
    MATFIT_CHECK(!released_, "LightStack: Plane()/data() after ReleaseSamples()");
    MATFIT_CHECK(type_ == SampleType::kFloat32,
                 "LightStack: Plane()/data() on a stack held at native depth "
                 "(uint8/uint16 codes); read it with Row/Texels/At/Sample, or convert it with "
                 "ToFloat()");
  }
  // lut[code] for n samples from sample index k into out.
  void Decode(int64_t k, int n, float* out) const;
  // lut_bytes_ from lut_ (after every change of lut_).
  void IndexLut();

  int width_ = 0, height_ = 0, channels_ = 0, num_images_ = 0;
  SampleType type_ = SampleType::kFloat32;
  bool released_ = false;
  // One of these holds the samples (the others are empty).
  std::vector<float, LargePageAllocator<float>> f32_;
  std::vector<uint8_t, LargePageAllocator<uint8_t>> u8_;
  std::vector<uint16_t, LargePageAllocator<uint16_t>> u16_;
  std::vector<float> lut_;
  // 8-bit stacks: lut_ as four 256-byte tables, byte q of every entry (the AVX-512 decode).
  std::vector<uint8_t> lut_bytes_;
  std::vector<LightSample> lights_;
  // A view: the source's first sample and, for each of this stack's images, the source's image
  // (its planes). Null for a stack that holds its samples.
  const void* borrowed_ = nullptr;
  std::vector<int> borrowed_images_;
};

// A stack holding only images `indices` of `stack` (in that order), with their lights and
// provenance; sample type and table, mask, view and physical size are kept.
LightStack SelectImages(const LightStack& stack, const std::vector<int>& indices);
// The same stack without copying a sample: a view that reads `stack`'s own planes (held-out
// folds, model selection). Valid while `stack` lives and its samples are neither written,
// reallocated nor released; the view's non-const sample accessors copy its images first (Own),
// so writing a view never changes `stack`. Copies of a view are views of the same source.
LightStack BorrowImages(const LightStack& stack, const std::vector<int>& indices);

// The images of each distinct view (ViewOf equal within 1e-9), views in order of first
// appearance, images in stack order (every light of a headers-only stack). One group for a
// single-view stack.
std::vector<std::vector<int>> ViewGroups(const LightStack& stack);
// The group of ViewGroups whose view is the most frontal (largest z; the first on ties).
int MostFrontalView(const LightStack& stack, const std::vector<std::vector<int>>& groups);
// The images of one view (a group of ViewGroups) as a single-view stack: SelectImages, with that
// view as the stack's view_direction and angles (as the reader gave them), so a single-view
// method fits them as it fits a BTF read with --view THETA,PHI.
LightStack SelectView(const LightStack& stack, const std::vector<int>& group);

}  // namespace matfit
