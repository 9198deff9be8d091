#include "core/dataset/stack_loader.h"

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <mutex>

#include "core/parallel.h"

namespace matfit {

StatusOr<LightStack> LoadStack(const std::vector<std::string>& files,
                               std::vector<LightSample> lights, const ImageReadOptions& options,
                               const ProgressFn& progress) {
  MATFIT_CHECK(files.size() == lights.size());
  if (files.empty()) return DataError("the dataset lists no images");
  ImageFileInfo first_info;
  auto first = ReadImage(files[0], options, &first_info);
  if (!first.ok()) return first.status();
  const int w = first->width(), h = first->height(), ch = first->channels();
  const int n = int(files.size());
  constexpr double kMaxStackBytes = 16.0 * (1ull << 30);  // 16 GiB: two thirds of this machine
  const double bytes = double(w) * h * ch * n * sizeof(float);
  if (bytes > kMaxStackBytes)
    return DataError(
        "the stack of " + std::to_string(n) + " images of " + std::to_string(w) + "x" +
        std::to_string(h) + " needs " + std::to_string(int64_t(bytes / (1 << 20))) +
        " MiB as float32, more than the 16 GiB limit; select one view or crop the images");
  LightStack stack(w, h, ch, n);
  stack.lights() = std::move(lights);
  stack.image_files = files;
  stack.encodings.resize(n);
  stack.encoding_reasons.resize(n);
  stack.saturated_pixels.assign(n, 0);
  stack.nonfinite_samples.assign(n, 0);

  std::vector<Status> errors(n);
  std::atomic<int64_t> done{0};
  std::mutex progress_mutex;
  auto store = [&](int i, const Image& img, const ImageFileInfo& info) {
    for (int c = 0; c < ch; ++c)
      std::copy_n(img.Plane(c).data(), img.plane_size(), stack.Plane(i, c).data());
    stack.encodings[i] = info.encoding;
    stack.encoding_reasons[i] = info.encoding_reason;
    stack.saturated_pixels[i] = info.saturated_pixels;
    stack.nonfinite_samples[i] = info.nonfinite_samples;
  };
  store(0, *first, first_info);
  first = Image();
  ParallelFor(1, n, [&](int64_t b, int64_t e) {
    for (int64_t i = b; i < e; ++i) {
      ImageFileInfo info;
      auto img = ReadImage(files[i], options, &info);
      if (!img.ok()) {
        errors[i] = img.status();
        continue;
      }
      if (img->width() != w || img->height() != h || img->channels() != ch) {
        errors[i] =
            DataError("image '" + files[i] + "' is " + std::to_string(img->width()) + "x" +
                      std::to_string(img->height()) + " with " + std::to_string(img->channels()) +
                      " channel(s) but '" + files[0] + "' is " + std::to_string(w) + "x" +
                      std::to_string(h) + " with " + std::to_string(ch) +
                      ": all images of a stack must have the same size and channels");
        continue;
      }
      store(int(i), *img, info);
      const int64_t d = ++done;
      if (progress) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        progress(d + 1, n);
      }
    }
  });
  for (const Status& s : errors)
    if (!s.ok()) return s;
  if (progress) progress(n, n);
  return stack;
}

StatusOr<std::vector<uint8_t>> ReadMaskImage(const std::string& path, int width, int height) {
  ImageReadOptions opt;
  opt.color_space = ColorSpaceChoice::kLinear;  // masks are data, not colour
  auto img = ReadImage(path, opt);
  if (!img.ok()) return Status(img.status().code(), "mask: " + img.status().message());
  if (img->width() != width || img->height() != height)
    return DataError("mask '" + path + "' is " + std::to_string(img->width()) + "x" +
                     std::to_string(img->height()) + " but the images are " +
                     std::to_string(width) + "x" + std::to_string(height));
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
