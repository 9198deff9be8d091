// Shared by the fuzz targets: a per-process scratch folder with tiny valid images, so that the
// readers get past "file not found" and exercise their parsing on every input.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace matfit::fuzz {

// A fresh folder under $TMPDIR, removed at exit.
const std::string& ScratchDir();
// Writes `size` bytes to `path` (truncating).
void WriteBytes(const std::string& path, const uint8_t* data, size_t size);
// Writes 4×4 RGB 16-bit PNGs named prefix + i + suffix for i in [first, first + count).
void WriteTinyImages(const std::string& dir, const std::string& prefix, const std::string& suffix,
                     int first, int count, int width = 4);

}  // namespace matfit::fuzz
