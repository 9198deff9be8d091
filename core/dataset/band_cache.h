// Out-of-core stacks (issue 17): a dataset too large for memory, decoded once into a cache on
// disk that holds it band-major — one file per band of rows, each the band's rows of every image
// at the files' native depth, in LightStack's plane order — so that a fit can load one band at a
// time. Building it decodes the images in chunks of at most `chunk_bytes` (in parallel within a
// chunk); loading a band is one sequential read. The cache files are removed with the cache.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/light_stack.h"
#include "core/progress_fn.h"

namespace matfit {

struct BandCacheOptions {
  // The largest band (and decode chunk), bytes at the stack's native depth; at least one row.
  int64_t band_bytes = int64_t(256) << 20;
  std::string dir;      // where the cache folder is made; empty: the system temp folder
  ProgressFn progress;  // images decoded (display only)
  bool Check(std::string* why) const;
};

class BandCache {
 public:
  // Decodes every image of `shape` (a headers-only read of the dataset: ReadOptions::headers_only,
  // its lights and image files) with the read options `read` (colour space, crop, confinement;
  // not rows or headers_only) into band files. All chunks must decode to the same sample type
  // and code table (mixed depths cannot be streamed: the error says so).
  static StatusOr<BandCache> Build(const LightStack& shape, const ReadOptions& read,
                                   const BandCacheOptions& options);
  BandCache(BandCache&&) noexcept;
  BandCache& operator=(BandCache&&) noexcept;
  BandCache(const BandCache&) = delete;
  ~BandCache();

  int bands() const { return int(row0_.size()); }
  int band_row0(int b) const { return row0_[size_t(b)]; }
  int band_rows(int b) const { return rows_[size_t(b)]; }
  int64_t bytes() const { return bytes_; }  // on disk, all bands
  const std::string& dir() const { return dir_; }
  // The stack without images: lights, views, how each image was decoded (encodings, clipping).
  const LightStack& meta() const { return meta_; }
  // The mask over every image (alpha in every image, LoadStack's rule); empty: none.
  const std::vector<uint8_t>& mask() const { return mask_; }
  // Band b as a stack of band_rows(b) rows: every image's rows, its lights (and views), code
  // table, mask rows and provenance; a standalone stack (row 0 = the band's first row).
  StatusOr<LightStack> Load(int b) const;

 private:
  BandCache() = default;
  std::string dir_;
  std::vector<int> row0_, rows_;
  int64_t bytes_ = 0;
  LightStack meta_;  // no images: the shape's lights and metadata, the type and table
  SampleType type_ = SampleType::kFloat32;
  std::vector<float> lut_;
  std::vector<uint8_t> mask_;  // whole stack (empty: none)
};

}  // namespace matfit
