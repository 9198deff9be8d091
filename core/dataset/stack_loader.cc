#include "core/dataset/stack_loader.h"

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <mutex>
#include <new>

#include "core/parallel.h"
#include "core/path_util.h"
#include "core/stack_band.h"
#include "core/stack_probe.h"
#include "core/warnings.h"

namespace matfit {

namespace {

bool SameEncoding(const ColorEncoding& a, const ColorEncoding& b) {
  return a.transfer == b.transfer && (a.transfer != TransferFunction::kGamma || a.gamma == b.gamma);
}

// Copies a decoded image into image i of the stack (whose sample type it has); an integer
// stack's planes come from `planes` ([i · channels + c], taken before decoding started).
void StorePlanes(const NativeImage& img, int i, LightStack* stack,
                 const std::vector<void*>& planes) {
  const int64_t n = stack->plane_size();
  for (int c = 0; c < img.channels; ++c) {
    void* to = planes.empty() ? nullptr : planes[size_t(i) * img.channels + c];
    switch (img.type) {
      case SampleType::kFloat32:
        std::copy_n(img.floats.Plane(c).data(), n, stack->Plane(i, c).data());
        break;
      case SampleType::kUint8:
        std::copy_n(img.u8.data() + c * n, n, static_cast<uint8_t*>(to));
        break;
      case SampleType::kUint16:
        std::copy_n(img.u16.data() + c * n, n, static_cast<uint16_t*>(to));
        break;
    }
  }
}

// Decodes files into a stack whose samples are of `type` with one transfer function
// (native: the first file's) or, with as_float, linear float32. Returns false in *uniform when a
// file's depth or transfer function differs from the first one's (the stack is then incomplete
// and the caller loads again as float).
StatusOr<LightStack> Load(const std::vector<std::string>& files, std::vector<LightSample> lights,
                          const ImageReadOptions& options, const ProgressFn& progress,
                          bool as_float, bool banded, const ProbeGrid* probe_grid, bool* uniform) {
  *uniform = true;
  ImageFileInfo first_info;
  auto read = [&](const std::string& path, ImageFileInfo* info) -> StatusOr<NativeImage> {
    if (!as_float) return ReadImageNative(path, options, info);
    auto img = ReadImage(path, options, info);
    if (!img.ok()) return img.status();
    NativeImage f;
    f.width = img->width(), f.height = img->height(), f.channels = img->channels();
    f.floats = std::move(*img);
    return f;
  };
  auto first = read(files[0], &first_info);
  if (!first.ok()) return first.status();
  const int w = first->width, h = first->height, ch = first->channels;
  const SampleType type = first->type;
  const int n = int(files.size());
  constexpr double kMaxStackBytes = 16.0 * (1ull << 30);  // 16 GiB: two thirds of this machine
  const double bytes = double(w) * h * ch * n * SampleBytes(type);
  if (bytes > kMaxStackBytes)
    return DataError("the stack of " + std::to_string(n) + " images of " + std::to_string(w) + "x" +
                     std::to_string(h) + " needs " + std::to_string(int64_t(bytes / (1 << 20))) +
                     " MiB as " + SampleTypeName(type) +
                     ", more than the 16 GiB limit; select one view or crop the images");
  std::vector<float> lut;
  if (type != SampleType::kFloat32)
    lut = LinearDecodeTable(first_info.encoding, type == SampleType::kUint8 ? 8 : 16);
  // Every sample is written by StorePlanes below (in the decoding threads) before the stack is
  // returned; a failed or mixed load discards it.
  LightStack stack(w, h, ch, n, type, std::move(lut), LightStack::Uninitialised{});
  stack.lights() = std::move(lights);
  stack.image_files = files;
  stack.encodings.resize(n);
  stack.encoding_reasons.resize(n);
  stack.saturated_pixels.assign(n, 0);
  stack.nonfinite_samples.assign(n, 0);
  // Every image's planes, taken here (Codes() drops the stack's probe, so it is not called by
  // the decoding threads).
  std::vector<void*> planes(size_t(n) * ch, nullptr);
  if (type != SampleType::kFloat32)
    for (int i = 0; i < n; ++i)
      for (int c = 0; c < ch; ++c)
        planes[size_t(i) * ch + c] = type == SampleType::kUint8
                                         ? static_cast<void*>(stack.Codes<uint8_t>(i, c).data())
                                         : static_cast<void*>(stack.Codes<uint16_t>(i, c).data());
  // The diagnosis's texels of each image, taken right after its decode (core/stack_probe.h):
  // integer single-view stacks of 1 to 4 channels (a multi-view stack is diagnosed on one
  // view's images) whose grid skips texels (step ≥ 3; a finer grid is most of the stack, which
  // DiagnoseStack then reads directly).
  std::shared_ptr<StackProbe> probe;
  if (probe_grid && type != SampleType::kFloat32 && !stack.is_multi_view() && n >= 6 && ch <= 4 &&
      probe_grid->step >= 3)
    probe = std::make_shared<StackProbe>(*probe_grid, n, ch);
  auto take_probe = [&](int i) {
    if (!probe) return;
    auto take = [&](auto zero) {
      using T = decltype(zero);
      const T* p[4] = {};
      for (int c = 0; c < ch; ++c) p[c] = static_cast<const T*>(planes[size_t(i) * ch + c]);
      probe->Take(i, p, w);
    };
    if (type == SampleType::kUint8)
      take(uint8_t{});
    else
      take(uint16_t{});
  };

  std::vector<Status> errors(n);
  std::atomic<int64_t> done{0};
  std::atomic<bool> mixed{false};
  std::mutex progress_mutex, alpha_mutex;
  int alpha_images = 0;
  auto store = [&](int i, const ImageFileInfo& info) {
    if (!info.alpha_mask.empty()) {  // a texel is a sample where every image's alpha says so
      std::lock_guard<std::mutex> lock(alpha_mutex);
      if (alpha_images++ == 0)
        stack.mask = info.alpha_mask;
      else
        for (size_t p = 0; p < stack.mask.size(); ++p) stack.mask[p] &= info.alpha_mask[p];
    }
    stack.encodings[i] = info.encoding;
    stack.encoding_reasons[i] = info.encoding_reason;
    stack.saturated_pixels[i] = info.saturated_pixels;
    stack.nonfinite_samples[i] = info.nonfinite_samples;
  };
  StorePlanes(*first, 0, &stack, planes);
  store(0, first_info);
  take_probe(0);
  first = NativeImage();
  // Integer files decode straight into the stack's planes (ReadImageInto: nothing is written
  // unless the file has the first one's size, channels, depth and transfer function); float
  // files are decoded one per task, then copied.
  auto mismatch = [&](int64_t i, int iw, int ih, int ic) {
    return DataError("image '" + files[size_t(i)] + "' is " + std::to_string(iw) + "x" +
                     std::to_string(ih) + " with " + std::to_string(ic) + " channel(s) but '" +
                     files[0] + "' is " + std::to_string(w) + "x" + std::to_string(h) + " with " +
                     std::to_string(ch) +
                     ": all images of a stack must have the same size and channels");
  };
  auto same_encoding = [&](const ImageFileInfo& info) {
    return SameEncoding(info.encoding, first_info.encoding);
  };
  ParallelFor(1, n, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      if (mixed) break;
      ImageFileInfo info;
      if (type != SampleType::kFloat32 && ch <= 4) {
        PlaneTarget target;
        target.width = w, target.height = h, target.channels = ch, target.type = type;
        for (int c = 0; c < ch; ++c) target.planes[c] = planes[size_t(i) * ch + c];
        ImageHeader shape;
        auto stored =
            ReadImageInto(files[size_t(i)], options, target, &info, &shape, same_encoding);
        if (!stored.ok()) {
          errors[i] = stored.status();
          continue;
        }
        if (!*stored) {
          if (shape.width != w || shape.height != h || shape.channels != ch) {
            errors[i] = mismatch(i, shape.width, shape.height, shape.channels);
            continue;
          }
          mixed = true;  // another depth or transfer function: the caller reloads as float
          break;
        }
      } else {
        auto img = read(files[i], &info);
        if (!img.ok()) {
          errors[i] = img.status();
          continue;
        }
        if (img->width != w || img->height != h || img->channels != ch) {
          errors[i] = mismatch(i, img->width, img->height, img->channels);
          continue;
        }
        if (img->type != type || (type != SampleType::kFloat32 && !same_encoding(info))) {
          mixed = true;  // one table cannot serve both: the caller reloads as float
          break;
        }
        StorePlanes(*img, int(i), &stack, planes);
      }
      store(int(i), info);
      take_probe(int(i));
      const int64_t d = ++done;
      if (progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        progress(d + 1, n);
      }
    }
  });
  for (const Status& s : errors)
    if (!s.ok()) return s;
  if (mixed) {
    *uniform = false;
    return stack;
  }
  if (progress) progress(n, n);
  stack.probe = std::move(probe);
  // A rank's band keeps its part of the alpha mask as it is: whether the whole mask is empty or
  // full is a question about every band (JoinBands, core/stack_band.h, answers it).
  if (alpha_images > 0 && banded) {
    stack.mask_source =
        "alpha channel (" + std::to_string(alpha_images) + " of " + std::to_string(n) + " images)";
  } else if (alpha_images > 0) {
    const int64_t inside = std::count(stack.mask.begin(), stack.mask.end(), uint8_t(1));
    const std::string of = std::to_string(alpha_images) + " of " + std::to_string(n) + " images";
    if (inside == 0) return AlphaTransparentError("alpha channel (" + of + ")");
    if (inside == int64_t(stack.mask.size())) {
      stack.mask.clear();  // opaque everywhere: every texel, no mask needed
      stack.mask_source = "none: the alpha channel (" + of + ") is opaque everywhere";
    } else {
      stack.mask_source = "alpha channel (" + of + ")";
    }
  }
  return stack;
}

}  // namespace

Status CheckCrop(const CropRect& c, int width, int height, const std::string& file) {
  if (c.x < 0 || c.y < 0 || c.w <= 0 || c.h <= 0 || int64_t(c.x) + c.w > width ||
      int64_t(c.y) + c.h > height)
    return DataError("--crop " + std::to_string(c.x) + "," + std::to_string(c.y) + "," +
                     std::to_string(c.w) + "," + std::to_string(c.h) +
                     " (x,y,width,height) reaches outside the " + std::to_string(width) + "x" +
                     std::to_string(height) + " images (e.g. '" + file +
                     "'); the region must lie inside them");
  return Status::Ok();
}

Status ApplyMaskFile(const std::string& path, const ReadOptions& o, LightStack* stack) {
  auto m = ReadMaskImage(path, stack->source_width, stack->source_height, o);
  if (!m.ok()) return m.status();
  const std::string shown = DatasetRelative(path, o.confine_to);
  if (stack->mask_source.rfind("alpha", 0) == 0)  // the file is the user's explicit choice
    stack->read_warnings.push_back(Warning(WarningCode::kAlphaDropped,
                                           "the images have an alpha channel, but the mask file '" +
                                               shown +
                                               "' is used instead; remove the mask file to mask by "
                                               "the alpha channel"));
  stack->mask = std::move(*m);
  stack->mask_source = "mask file '" + shown + "'";
  return Status::Ok();
}

StatusOr<LightStack> LoadStack(const std::vector<std::string>& files,
                               std::vector<LightSample> lights, const ImageReadOptions& options_in,
                               const ReadOptions& o) {
  MATFIT_CHECK(files.size() == lights.size());
  if (files.empty()) return DataError("the dataset lists no images");
  ImageReadOptions options = options_in;
  options.confine_to = o.confine_to;
  // Headers first: a decompression bomb (tiny files declaring huge images) is refused here,
  // before a pixel is decoded or a byte of the stack allocated.
  auto first = ReadImageHeader(files[0], options);
  if (!first.ok()) return first.status();
  const int source_w = first->width, source_h = first->height, ch = first->channels;
  const int n = int(files.size());
  auto shown = [&](const std::string& f) { return DatasetRelative(f, o.confine_to); };
  // Read in parallel (a file's header costs three opens and a parse: ~40 µs each, 9 ms of one
  // thread for 240 JPEGs), checked in file order: the first bad file is the one reported.
  std::vector<StatusOr<ImageHeader>> headers(size_t(n), ImageHeader{});
  ParallelFor(1, n, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) headers[size_t(i)] = ReadImageHeader(files[size_t(i)], options);
  });
  for (int i = 1; i < n; ++i) {
    const StatusOr<ImageHeader>& hd = headers[size_t(i)];
    if (!hd.ok()) return hd.status();
    if (hd->width != source_w || hd->height != source_h || hd->channels != ch)
      return DataError("image '" + shown(files[i]) + "' is " + std::to_string(hd->width) + "x" +
                       std::to_string(hd->height) + " with " + std::to_string(hd->channels) +
                       " channel(s) but '" + shown(files[0]) + "' is " + std::to_string(source_w) +
                       "x" + std::to_string(source_h) + " with " + std::to_string(ch) +
                       ": all images of a stack must have the same size and channels");
  }
  // The region read: the crop, or the whole images.
  const CropRect region = o.crop ? *o.crop : CropRect{0, 0, source_w, source_h};
  MATFIT_RETURN_IF_ERROR(CheckCrop(region, source_w, source_h, shown(files[0])));
  const int w = region.w, h = region.h;
  if (o.crop) options.col0 = region.x, options.cols = region.w;
  if (!o.headers_only) {
    options.row0 = region.y + (o.rows > 0 ? o.row0 : 0);  // row0 alone means nothing
    options.rows = o.rows > 0 ? o.rows : (o.crop ? region.h : 0);
    options.alpha_mask = !options.all_channels;  // RGBA / grey+alpha: alpha is the mask
  }
  if (o.rows > 0 && (o.row0 < 0 || o.row0 + o.rows > h))
    return DataError("rows " + std::to_string(o.row0) + ".." + std::to_string(o.row0 + o.rows - 1) +
                     " were asked for but the images have " + std::to_string(h) + " rows");
  const std::string size_text = std::to_string(n) + " images of " + std::to_string(w) + "x" +
                                std::to_string(h) + " with " + std::to_string(ch) + " channel(s)";
  const int64_t samples = int64_t(n) * w * h * ch;
  if (o.max_stack_samples > 0 && samples > o.max_stack_samples)
    return DataError("the dataset's " + size_text + " hold " + std::to_string(samples) +
                     " samples (images × width × height × channels), more than the limit of " +
                     std::to_string(o.max_stack_samples) +
                     "; select fewer images or one view, or crop or downscale them");
  auto provenance = [&](LightStack* s) {
    s->source_width = source_w, s->source_height = source_h;
    if (o.crop)
      s->crop_x = region.x, s->crop_y = region.y, s->crop_w = region.w, s->crop_h = region.h;
  };
  if (o.headers_only) {
    LightStack stack(w, h, ch, 0);  // the size and the lights, no images
    stack.lights() = std::move(lights);
    stack.image_files = files;
    provenance(&stack);
    return stack;
  }
  try {
    bool uniform = true;
    // The diagnosis's grid over the whole region; a band takes its rows of it.
    const ProbeGrid grid =
        MakeProbeGrid(w, h, o.rows > 0 ? o.row0 : 0, o.rows > 0 ? o.rows : h, kProbeTexels);
    auto stack = Load(files, lights, options, o.progress, /*as_float=*/false, o.rows > 0,
                      o.diagnosis_probe ? &grid : nullptr, &uniform);
    if (stack.ok() && !uniform) {
      // Files of mixed depth or transfer function: linear float32, as every image decodes alone.
      *stack = LightStack();
      stack = Load(files, std::move(lights), options, o.progress, /*as_float=*/true, o.rows > 0,
                   nullptr, &uniform);
    }
    if (stack.ok()) provenance(&*stack);
    if (stack.ok() && o.rows > 0) stack->band.row0 = o.row0, stack->band.full_height = h;
    return stack;
  } catch (const std::bad_alloc&) {
    return DataError("the stack of " + size_text + " (" + std::to_string(samples) +
                     " samples, from '" + shown(files[0]) +
                     "' on) does not fit in memory: the allocation failed. Select fewer images "
                     "or one view, crop or downscale them, or use a machine with more memory");
  }
}

StatusOr<std::vector<uint8_t>> ReadMaskImage(const std::string& path, int width, int height,
                                             const ReadOptions& o) {
  ImageReadOptions opt;
  opt.color_space = ColorSpaceChoice::kLinear;  // masks are data, not colour
  opt.confine_to = o.confine_to;
  {  // the whole mask's size, also when only a band of its rows is read
    auto hd = ReadImageHeader(path, opt);
    if (!hd.ok()) return Status(hd.status().code(), "mask: " + hd.status().message());
    if (hd->width != width || hd->height != height)
      return DataError("mask '" + DatasetRelative(path, o.confine_to) + "' is " +
                       std::to_string(hd->width) + "x" + std::to_string(hd->height) +
                       " but the images are " + std::to_string(width) + "x" +
                       std::to_string(height));
    if (o.headers_only) return std::vector<uint8_t>();
  }
  const CropRect region = o.crop ? *o.crop : CropRect{0, 0, width, height};
  MATFIT_RETURN_IF_ERROR(CheckCrop(region, width, height, DatasetRelative(path, o.confine_to)));
  if (o.crop) opt.col0 = region.x, opt.cols = width = region.w;
  if (o.rows > 0)
    opt.row0 = region.y + o.row0, opt.rows = height = o.rows;
  else if (o.crop)
    opt.row0 = region.y, opt.rows = height = region.h;
  auto img = ReadImage(path, opt);
  if (!img.ok()) return Status(img.status().code(), "mask: " + img.status().message());
  if (img->width() != width || img->height() != height)
    return DataError("mask '" + DatasetRelative(path, o.confine_to) + "' is " +
                     std::to_string(img->width()) + "x" + std::to_string(img->height()) +
                     " but the images are " + std::to_string(width) + "x" + std::to_string(height));
  std::vector<uint8_t> mask(size_t(width) * height);
  auto plane = img->Plane(0);
  for (size_t i = 0; i < mask.size(); ++i) mask[i] = plane[i] > 0.5f ? 1 : 0;
  return mask;
}

std::string FolderName(const std::string& dir) {
  std::string d = dir;
  while (d.size() > 1 && d.back() == '/') d.pop_back();
  return std::filesystem::path(d).filename().string();
}

StatusOr<LightSample> MakeLight(const Vec3& direction, const std::string& where) {
  if (!IsFinite(direction))
    return DataError(where + ": light direction has a non-finite component (NaN or Inf)");
  const double len = Length(direction);
  if (!(len > 1e-9)) return DataError(where + ": light direction is the zero vector");
  LightSample s;
  s.direction = direction / len;
  AnglesDegFromDirection(s.direction, &s.theta_deg, &s.phi_deg);
  return s;
}

}  // namespace matfit
