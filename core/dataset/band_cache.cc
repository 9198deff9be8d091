#include "core/dataset/band_cache.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <utility>

#include "core/dataset/stack_loader.h"
#include "core/path_util.h"
#include "core/sample_type.h"
#include "core/stack_ops.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

// The samples of a stack as bytes (every plane, in plane order): one contiguous block, so not
// a view's (BorrowImages: its planes are its source's, in the source's order).
const char* Bytes(const LightStack& s) {
  MATFIT_CHECK(!s.is_view(), "band cache: a view of a stack has no contiguous samples");
  switch (s.sample_type()) {
    case SampleType::kUint8: return reinterpret_cast<const char*>(s.Codes<uint8_t>(0, 0).data());
    case SampleType::kUint16: return reinterpret_cast<const char*>(s.Codes<uint16_t>(0, 0).data());
    case SampleType::kFloat32: break;
  }
  return reinterpret_cast<const char*>(s.data());
}
char* Bytes(LightStack& s) {
  switch (s.sample_type()) {
    case SampleType::kUint8: return reinterpret_cast<char*>(s.Codes<uint8_t>(0, 0).data());
    case SampleType::kUint16: return reinterpret_cast<char*>(s.Codes<uint16_t>(0, 0).data());
    case SampleType::kFloat32: break;
  }
  return reinterpret_cast<char*>(s.data());
}

std::string BandFile(const std::string& dir, int b) {
  char name[32];
  std::snprintf(name, sizeof name, "band_%05d.bin", b);
  return (fs::path(dir) / name).string();
}

// `err`: the errno of the failed call (0: a short read or write, e.g. a truncated file).
Status FileError(const std::string& what, const std::string& path, int err) {
  return IoError(what + " '" + path + "': " +
                 (err ? std::string(std::strerror(err)) : std::string("short read or write")) +
                 (err == ENOSPC || err == EDQUOT
                      ? " (the out-of-core cache needs room for the whole stack at its native "
                        "depth; point --cache-dir at a disk that has it)"
                      : ""));
}

}  // namespace

bool BandCacheOptions::Check(std::string* why) const {
  if (band_bytes < 1) {
    *why = "the band size must be positive, got " + std::to_string(band_bytes);
    return false;
  }
  return true;
}

BandCache::BandCache(BandCache&& o) noexcept { *this = std::move(o); }
BandCache& BandCache::operator=(BandCache&& o) noexcept {
  if (this == &o) return *this;
  if (!dir_.empty()) {  // this cache's files go now, not with the moved-from object
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  dir_ = std::move(o.dir_);
  o.dir_.clear();
  row0_ = std::move(o.row0_), rows_ = std::move(o.rows_);
  bytes_ = o.bytes_;
  meta_ = std::move(o.meta_);
  type_ = o.type_;
  lut_ = std::move(o.lut_);
  mask_ = std::move(o.mask_);
  return *this;
}
BandCache::~BandCache() {
  if (dir_.empty()) return;
  std::error_code ec;
  fs::remove_all(dir_, ec);
}

StatusOr<BandCache> BandCache::Build(const LightStack& shape, const ReadOptions& read,
                                     const BandCacheOptions& o) {
  std::string why;
  if (!o.Check(&why)) return InvalidArgument(why);
  const int n = int(shape.lights().size()), W = shape.width(), H = shape.height();
  const int C = shape.channels();
  if (n == 0 || W <= 0 || H <= 0 || int(shape.image_files.size()) != n)
    return InvalidArgument(
        "the out-of-core cache needs the dataset's image list (a headers-only "
        "read)");
  BandCache cache;
  cache.meta_ = shape;  // lights, views, provenance; no images
  std::error_code ec;
  const fs::path parent = o.dir.empty() ? fs::temp_directory_path(ec) : fs::path(o.dir);
  if (ec)
    return IoError("no temporary folder for the out-of-core cache (" + ec.message() +
                   "); give one with --cache-dir");
  std::string templ = (parent / "matfit-cache-XXXXXX").string();
  if (!::mkdtemp(templ.data()))
    return FileError("cannot create the cache folder in", parent.string(), errno);
  cache.dir_ = templ;

  ImageReadOptions io;
  io.color_space = read.color_space;
  io.confine_to = read.confine_to;
  ReadOptions chunk_read = read;
  chunk_read.view.reset();
  chunk_read.all_views = false;
  chunk_read.headers_only = false;
  chunk_read.row0 = chunk_read.rows = 0;
  chunk_read.progress = {};
  chunk_read.max_stack_samples = 0;  // the whole dataset was checked by the headers-only read
  const int64_t image_samples = int64_t(W) * H * C;
  // Chunks and bands are sized at float32 until the first chunk tells the native depth.
  int chunk = int(std::clamp<int64_t>(o.band_bytes / (image_samples * 4), 1, n));
  int64_t bps = 0;  // bytes per sample, from the first chunk
  cache.meta_.encodings.clear(), cache.meta_.encoding_reasons.clear();
  cache.meta_.saturated_pixels.clear(), cache.meta_.nonfinite_samples.clear();
  for (int i0 = 0, i1 = 0; i0 < n; i0 = i1) {  // the chunk grows after the first: step by i1
    i1 = std::min(n, i0 + chunk);
    std::vector<std::string> files(shape.image_files.begin() + i0, shape.image_files.begin() + i1);
    std::vector<LightSample> lights(shape.lights().begin() + i0, shape.lights().begin() + i1);
    auto part = LoadStack(files, std::move(lights), io, chunk_read);
    if (!part.ok()) return part.status();
    // The header read sized everything: a chunk that decodes to another shape is refused.
    if (part->width() != W || part->height() != H || part->channels() != C ||
        part->num_images() != i1 - i0)
      return DataError("'" + DatasetRelative(files[0], read.confine_to) +
                       "' and the images after it decode to " + std::to_string(part->width()) +
                       "x" + std::to_string(part->height()) + " with " +
                       std::to_string(part->channels()) + " channel(s), but '" +
                       DatasetRelative(shape.image_files[0], read.confine_to) + "' is " +
                       std::to_string(W) + "x" + std::to_string(H) + " with " + std::to_string(C) +
                       ": all images of a stack must have the same size and channels");
    if (i0 == 0) {  // the native depth: bands and chunks at their real size from here on
      cache.type_ = part->sample_type(), cache.lut_ = part->lut();
      bps = SampleBytes(cache.type_);
      chunk = int(std::clamp<int64_t>(o.band_bytes / (image_samples * bps), 1, n));
      const int64_t row_bytes = int64_t(n) * C * W * bps;
      const int rows = int(std::clamp<int64_t>(o.band_bytes / row_bytes, 1, H));
      for (int r0 = 0; r0 < H; r0 += rows)
        cache.row0_.push_back(r0), cache.rows_.push_back(std::min(rows, H - r0));
    } else if (part->sample_type() != cache.type_ || part->lut() != cache.lut_) {
      return DataError("'" + DatasetRelative(files[0], read.confine_to) +
                       "' decodes to another sample depth or transfer function than '" +
                       DatasetRelative(shape.image_files[0], read.confine_to) +
                       "': a dataset of mixed files is read in memory only (raise --memory)");
    }
    if (part->has_mask()) {  // a sample where every image's alpha says so (LoadStack's rule)
      if (cache.mask_.empty()) cache.mask_.assign(size_t(W) * H, 1);
      for (size_t p = 0; p < cache.mask_.size(); ++p) cache.mask_[p] &= part->mask[p];
      cache.meta_.mask_source = part->mask_source;
    }
    auto append = [](auto& dst, const auto& src) { dst.insert(dst.end(), src.begin(), src.end()); };
    append(cache.meta_.encodings, part->encodings);
    append(cache.meta_.encoding_reasons, part->encoding_reasons);
    append(cache.meta_.saturated_pixels, part->saturated_pixels);
    append(cache.meta_.nonfinite_samples, part->nonfinite_samples);
    append(cache.meta_.read_warnings, part->read_warnings);
    // Each band file: planes (image, channel) of band_rows × W samples, in stack order. One band
    // file open at a time (a tall stack under a small budget has thousands of bands).
    const char* src = Bytes(std::as_const(*part));
    for (int b = 0; b < cache.bands(); ++b) {
      const std::string path = BandFile(cache.dir_, b);
      const int fd = ::open(path.c_str(), O_CREAT | O_WRONLY | O_CLOEXEC, 0600);
      if (fd < 0) return FileError("cannot create the cache file", path, errno);
      const int64_t len = int64_t(cache.rows_[size_t(b)]) * W * bps;
      for (int k = 0; k < i1 - i0; ++k)
        for (int c = 0; c < C; ++c) {
          const char* from =
              src + ((int64_t(k) * C + c) * H + cache.row0_[size_t(b)]) * int64_t(W) * bps;
          const int64_t at = (int64_t(i0 + k) * C + c) * len;
          for (int64_t done = 0; done < len;) {
            errno = 0;
            const ssize_t w = ::pwrite(fd, from + done, size_t(len - done), at + done);
            if (w <= 0) {
              const int err = errno;
              ::close(fd);
              return FileError("cannot write the cache file", path, err);
            }
            done += w;
          }
        }
      ::close(fd);
    }
    if (o.progress && !o.progress(i1, n)) return Status(StatusCode::kCancelled, "cancelled");
  }
  cache.bytes_ = int64_t(n) * image_samples * bps;
  return cache;
}

StatusOr<LightStack> BandCache::Load(int b) const {
  const int W = meta_.width(), C = meta_.channels(), rows = rows_[size_t(b)];
  const int n = int(meta_.lights().size());
  LightStack s(W, rows, C, n, type_, lut_, LightStack::Uninitialised{});
  const std::string path = BandFile(dir_, b);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return FileError("cannot open the cache file", path, errno);
  char* dst = Bytes(s);
  const int64_t len = int64_t(n) * C * rows * W * SampleBytes(type_);
  for (int64_t done = 0; done < len;) {
    errno = 0;
    const ssize_t r = ::pread(fd, dst + done, size_t(len - done), done);
    if (r <= 0) {
      const int err = errno;
      ::close(fd);
      return FileError("cannot read the cache file", path, err);
    }
    done += r;
  }
  ::close(fd);
  CopyStackMetadata(meta_, &s);  // a standalone stack of the band's rows: no band record
  s.band = StackBand{};
  if (!mask_.empty())
    s.mask.assign(mask_.begin() + int64_t(row0_[size_t(b)]) * W,
                  mask_.begin() + int64_t(row0_[size_t(b)] + rows) * W);
  return s;
}

}  // namespace matfit
