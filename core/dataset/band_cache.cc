#include "core/dataset/band_cache.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>

#include "core/dataset/stack_loader.h"
#include "core/path_util.h"
#include "core/sample_type.h"

namespace matfit {
namespace {

namespace fs = std::filesystem;

// The samples of a stack as bytes (every plane, in plane order): one contiguous block.
const char* Bytes(const LightStack& s) {
  switch (s.sample_type()) {
    case SampleType::kUint8: return reinterpret_cast<const char*>(s.Codes<uint8_t>(0, 0).data());
    case SampleType::kUint16: return reinterpret_cast<const char*>(s.Codes<uint16_t>(0, 0).data());
    case SampleType::kFloat32: break;
  }
  return reinterpret_cast<const char*>(s.data());
}
char* Bytes(LightStack& s) { return const_cast<char*>(Bytes(std::as_const(s))); }

std::string BandFile(const std::string& dir, int b) {
  char name[32];
  std::snprintf(name, sizeof name, "band_%05d.bin", b);
  return (fs::path(dir) / name).string();
}

Status FileError(const std::string& what, const std::string& path) {
  return IoError(what + " '" + path + "': " + std::strerror(errno) +
                 " (the out-of-core cache needs room for the whole stack at its native depth; "
                 "point --cache-dir at a disk that has it)");
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
  const fs::path parent = o.dir.empty() ? fs::temp_directory_path() : fs::path(o.dir);
  std::string templ = (parent / "matfit-cache-XXXXXX").string();
  if (!::mkdtemp(templ.data()))
    return FileError("cannot create the cache folder in", parent.string());
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
  std::vector<int> fds;
  auto close_all = [&] {
    for (int fd : fds) ::close(fd);
    fds.clear();
  };
  cache.meta_.encodings.clear(), cache.meta_.encoding_reasons.clear();
  cache.meta_.saturated_pixels.clear(), cache.meta_.nonfinite_samples.clear();
  for (int i0 = 0, i1 = 0; i0 < n; i0 = i1) {  // the chunk grows after the first: step by i1
    i1 = std::min(n, i0 + chunk);
    std::vector<std::string> files(shape.image_files.begin() + i0, shape.image_files.begin() + i1);
    std::vector<LightSample> lights(shape.lights().begin() + i0, shape.lights().begin() + i1);
    auto part = LoadStack(files, std::move(lights), io, chunk_read);
    if (!part.ok()) {
      close_all();
      return part.status();
    }
    if (i0 == 0) {  // the native depth: bands and chunks at their real size from here on
      cache.type_ = part->sample_type(), cache.lut_ = part->lut();
      bps = SampleBytes(cache.type_);
      chunk = int(std::clamp<int64_t>(o.band_bytes / (image_samples * bps), 1, n));
      const int64_t row_bytes = int64_t(n) * C * W * bps;
      const int rows = int(std::clamp<int64_t>(o.band_bytes / row_bytes, 1, H));
      for (int r0 = 0; r0 < H; r0 += rows)
        cache.row0_.push_back(r0), cache.rows_.push_back(std::min(rows, H - r0));
      for (int b = 0; b < cache.bands(); ++b) {
        const std::string path = BandFile(cache.dir_, b);
        const int fd = ::open(path.c_str(), O_CREAT | O_TRUNC | O_WRONLY | O_CLOEXEC, 0600);
        if (fd < 0) {
          close_all();
          return FileError("cannot create the cache file", path);
        }
        fds.push_back(fd);
      }
    } else if (part->sample_type() != cache.type_ || part->lut() != cache.lut_) {
      close_all();
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
    // Each band file: planes (image, channel) of band_rows × W samples, in stack order.
    const char* src = Bytes(*part);
    for (int k = 0; k < i1 - i0; ++k)
      for (int c = 0; c < C; ++c) {
        const char* plane = src + (int64_t(k) * C + c) * W * H * bps;
        for (int b = 0; b < cache.bands(); ++b) {
          const int64_t len = int64_t(cache.rows_[size_t(b)]) * W * bps;
          const int64_t at = (int64_t(i0 + k) * C + c) * len;
          const char* from = plane + int64_t(cache.row0_[size_t(b)]) * W * bps;
          for (int64_t done = 0; done < len;) {
            const ssize_t w = ::pwrite(fds[size_t(b)], from + done, size_t(len - done), at + done);
            if (w <= 0) {
              const std::string path = BandFile(cache.dir_, b);
              close_all();
              return FileError("cannot write the cache file", path);
            }
            done += w;
          }
        }
      }
    if (o.progress) o.progress(i1, n);
  }
  close_all();
  cache.bytes_ = int64_t(n) * image_samples * bps;
  return cache;
}

StatusOr<LightStack> BandCache::Load(int b) const {
  const int W = meta_.width(), C = meta_.channels(), rows = rows_[size_t(b)];
  const int n = int(meta_.lights().size());
  LightStack s(W, rows, C, n, type_, lut_, LightStack::Uninitialised{});
  const std::string path = BandFile(dir_, b);
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return FileError("cannot open the cache file", path);
  char* dst = Bytes(s);
  const int64_t len = int64_t(n) * C * rows * W * SampleBytes(type_);
  for (int64_t done = 0; done < len;) {
    const ssize_t r = ::pread(fd, dst + done, size_t(len - done), done);
    if (r <= 0) {
      ::close(fd);
      return FileError("cannot read the cache file", path);
    }
    done += r;
  }
  ::close(fd);
  s.lights() = meta_.lights();
  s.view_direction = meta_.view_direction;
  s.view_theta_deg = meta_.view_theta_deg, s.view_phi_deg = meta_.view_phi_deg;
  s.mm_per_texel = meta_.mm_per_texel;
  s.layout = meta_.layout, s.source = meta_.source, s.object_name = meta_.object_name;
  s.image_files = meta_.image_files;
  s.encodings = meta_.encodings, s.encoding_reasons = meta_.encoding_reasons;
  s.saturated_pixels = meta_.saturated_pixels, s.nonfinite_samples = meta_.nonfinite_samples;
  s.mask_source = meta_.mask_source;
  if (!mask_.empty())
    s.mask.assign(mask_.begin() + int64_t(row0_[size_t(b)]) * W,
                  mask_.begin() + int64_t(row0_[size_t(b)] + rows) * W);
  return s;
}

}  // namespace matfit
