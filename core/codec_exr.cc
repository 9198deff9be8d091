// OpenEXR through its own library, read as OpenImageIO 2.4 reads it: the first part's data
// window; channels R, G, B, A in that order, one channel of any name, or matfit's data planes
// ch00, ch01, ... (other layouts, deep, sub-sampled and integer channels are declined); half
// and float samples; colour space "Linear" unless an "oiio:ColorSpace" attribute says otherwise,
// "oiio:Gamma" and "Software" from their attributes. Written as OpenImageIO writes matfit's maps:
// channels Y / R,G / R,G,B / R,G,B,A / ch00…, uncompressed or PIZ.
#include <Imath/half.h>
#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFloatAttribute.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>
#include <OpenEXR/ImfStringAttribute.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "core/codec_native.h"

namespace matfit::codec {
namespace {

std::string ChannelName(int c, int channels) {
  static const char* kRgba[] = {"R", "G", "B", "A"};
  if (channels == 1) return "Y";
  if (channels <= 4) return kRgba[c];
  char name[16];
  std::snprintf(name, sizeof name, "ch%02d", c);
  return name;
}

// The file's channels in OpenImageIO's order, or empty when the layout is declined.
std::vector<std::string> OrderedChannels(const Imf::ChannelList& list, Imf::PixelType* type) {
  std::vector<std::string> names;
  bool first = true;
  for (auto it = list.begin(); it != list.end(); ++it) {
    const Imf::Channel& ch = it.channel();
    if (ch.xSampling != 1 || ch.ySampling != 1) return {};
    if (ch.type == Imf::UINT || (!first && ch.type != *type)) return {};
    *type = ch.type;
    first = false;
    names.push_back(it.name());
  }
  if (names.size() <= 1) return names;
  std::vector<std::string> rgba;
  for (const char* n : {"R", "G", "B", "A"})
    if (std::find(names.begin(), names.end(), n) != names.end()) rgba.push_back(n);
  if (rgba.size() == names.size()) return rgba;
  // ch00, ch01, ...: the list is sorted by name, which is their numeric order.
  if (names.size() <= 4) return {};
  for (size_t i = 0; i < names.size(); ++i)
    if (names[i] != ChannelName(int(i), int(names.size()))) return {};
  return names;
}

class ExrReader : public Reader {
 public:
  explicit ExrReader(std::unique_ptr<Imf::InputFile> file) : file_(std::move(file)) {}

  bool OpenHeader() {
    const Imf::Header& hdr = file_->header();
    if (hdr.hasType() && hdr.type().rfind("deep", 0) == 0) return false;
    Imf::PixelType type = Imf::HALF;
    channels_ = OrderedChannels(hdr.channels(), &type);
    if (channels_.empty()) return false;
    const Imath::Box2i dw = hdr.dataWindow();
    h_.width = dw.max.x - dw.min.x + 1;
    h_.height = dw.max.y - dw.min.y + 1;
    h_.channels = int(channels_.size());
    h_.sample = type == Imf::HALF ? Sample::kHalf : Sample::kFloat;
    h_.color_space = "Linear";  // OpenImageIO's name for every EXR without its own tag
    if (auto* cs = hdr.findTypedAttribute<Imf::StringAttribute>("oiio:ColorSpace"))
      h_.color_space = cs->value();
    if (auto* g = hdr.findTypedAttribute<Imf::FloatAttribute>("oiio:Gamma")) h_.gamma = g->value();
    if (auto* s = hdr.findTypedAttribute<Imf::StringAttribute>("Software"))
      h_.software = s->value();
    h_.software_known = true;
    return h_.width > 0 && h_.height > 0;
  }

  const Header& header() const override { return h_; }

  bool ReadRows(int y0, int y1, void* dst) override {
    try {
      const Imath::Box2i dw = file_->header().dataWindow();
      const size_t px = sizeof(float) * size_t(h_.channels);
      const size_t row = px * size_t(h_.width);
      // Slice bases are addressed by absolute pixel coordinates: shift by the window origin and
      // the band's first row.
      char* base = static_cast<char*>(dst) - ptrdiff_t(dw.min.x) * ptrdiff_t(px) -
                   ptrdiff_t(dw.min.y + y0) * ptrdiff_t(row);
      Imf::FrameBuffer fb;
      for (int c = 0; c < h_.channels; ++c)
        fb.insert(channels_[size_t(c)],
                  Imf::Slice(Imf::FLOAT, base + sizeof(float) * size_t(c), px, row));
      file_->setFrameBuffer(fb);
      file_->readPixels(dw.min.y + y0, dw.min.y + y1 - 1);  // only the band's rows
      return true;
    } catch (const std::exception& e) {
      error_ = e.what();
      return false;
    }
  }

  std::string error() const override { return error_.empty() ? "unknown EXR error" : error_; }

 private:
  std::unique_ptr<Imf::InputFile> file_;
  std::vector<std::string> channels_;
  Header h_;
  std::string error_;
};

}  // namespace

namespace {

// The most raw bytes per file byte that a compression can give, generously: none stores them;
// RLE packs a run of 128 bytes in 2; ZIP and PXR24 are deflate (at most 1032:1); PIZ's Huffman
// codes runs of zeros (4096:1 covers it); B44 is at most 32:1. DWA (lossy DCT) has no useful
// bound: 0, not checked.
double MaxExpansion(Imf::Compression c) {
  switch (c) {
    case Imf::NO_COMPRESSION: return 1.0;
    case Imf::RLE_COMPRESSION: return 64.0;
    case Imf::ZIPS_COMPRESSION:
    case Imf::ZIP_COMPRESSION:
    case Imf::PXR24_COMPRESSION: return 1032.0;
    case Imf::PIZ_COMPRESSION: return 4096.0;
    case Imf::B44_COMPRESSION:
    case Imf::B44A_COMPRESSION: return 32.0;
    default: return 0.0;
  }
}

// A header whose pixels cannot fit in the file at its compression's best ratio (truncated, or
// a lying header: a decompression bomb's cheap form) is refused before pixels are allocated.
bool HoldsItsPixels(const Imf::Header& hdr, const std::string& path, std::string* error) {
  const Imath::Box2i dw = hdr.dataWindow();
  double raw = 0.0;
  for (auto it = hdr.channels().begin(); it != hdr.channels().end(); ++it)
    raw += (it.channel().type == Imf::HALF ? 2.0 : 4.0) * (double(dw.max.x) - dw.min.x + 1) *
           (double(dw.max.y) - dw.min.y + 1);
  const double ratio = MaxExpansion(hdr.compression());
  std::error_code ec;
  const double size = double(std::filesystem::file_size(path, ec));
  if (ec || ratio == 0.0 || raw <= ratio * size) return true;
  char msg[320];
  std::snprintf(msg, sizeof msg,
                "the header declares %.0fx%.0f pixels (%.0f MiB of samples) but the file has "
                "only %.0f bytes, more than its compression can hold (at most %.0f:1): it is "
                "truncated or its header is wrong",
                double(dw.max.x) - dw.min.x + 1, double(dw.max.y) - dw.min.y + 1,
                raw / double(1 << 20), size, ratio);
  *error = msg;
  return false;
}

}  // namespace

// Walks the first header's attributes (name\0 type\0 int32 size, value) and checks that each
// value fits in the file: OpenEXR 3.1 allocates a declared size before reading it, so a few
// hostile bytes could ask for gigabytes.
bool AttributesFit(const std::string& path, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  if (!in || ec) return true;  // OpenEXR reports it
  in.seekg(8);                 // magic, version and flags
  auto read_name = [&](std::string* out) {
    out->clear();
    for (char c; in.get(c);) {
      if (c == '\0') return true;
      if (out->size() >= 255) return false;
      out->push_back(c);
    }
    return false;
  };
  std::string name, type;
  for (int n = 0; n < 100000; ++n) {
    if (!read_name(&name)) return true;  // truncated or odd: OpenEXR explains it
    if (name.empty()) return true;       // end of the header
    unsigned char b[4];
    if (!read_name(&type) || !in.read(reinterpret_cast<char*>(b), 4)) return true;
    const int64_t value =
        int64_t(uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24);
    const int64_t pos = int64_t(in.tellg());
    if (pos < 0 || value > int64_t(size) - pos) {
      *error = "its header attribute '" + name + "' (" + type + ") declares " +
               std::to_string(value) + " bytes, more than the file holds (" + std::to_string(size) +
               " bytes): it is truncated or corrupt";
      return false;
    }
    in.seekg(value, std::ios::cur);
  }
  return true;
}

std::unique_ptr<Reader> OpenExr(const std::string& path, std::string* error) {
  if (!AttributesFit(path, error)) return nullptr;
  try {
    auto file = std::make_unique<Imf::InputFile>(path.c_str());
    if (!HoldsItsPixels(file->header(), path, error)) return nullptr;
    auto r = std::make_unique<ExrReader>(std::move(file));
    if (r->OpenHeader()) return r;
    return nullptr;  // declined: OpenImageIO reads this layout
  } catch (const std::exception& e) {
    *error = e.what();
    return nullptr;
  }
}

bool WriteExr(const WriteSpec& w, const std::string& path, std::string* error) {
  if (w.sample != Sample::kHalf && w.sample != Sample::kFloat) {
    *error = "matfit writes EXR as half or float";
    return false;
  }
  try {
    Imf::Header hdr(w.width, w.height);
    hdr.compression() = w.compact ? Imf::PIZ_COMPRESSION : Imf::NO_COMPRESSION;
    const Imf::PixelType type = w.sample == Sample::kHalf ? Imf::HALF : Imf::FLOAT;
    for (int c = 0; c < w.channels; ++c)
      hdr.channels().insert(ChannelName(c, w.channels), Imf::Channel(type));
    hdr.insert("oiio:ColorSpace", Imf::StringAttribute(w.srgb ? "sRGB" : "Linear"));
    if (!w.srgb) hdr.insert("oiio:Gamma", Imf::FloatAttribute(1.0f));
    hdr.insert("Software", Imf::StringAttribute(w.software));
    Imf::OutputFile out(path.c_str(), hdr);
    // The writer does not convert: half files get half samples (rounded to nearest).
    const size_t bytes = type == Imf::HALF ? sizeof(Imath::half) : sizeof(float);
    const size_t px = bytes * size_t(w.channels);
    const size_t row = px * size_t(w.width);
    std::vector<Imath::half> halves;
    for (int y0 = 0; y0 < w.height; y0 += w.strip_rows) {
      const int y1 = std::min(w.height, y0 + w.strip_rows);
      // The strip holds rows y0..y1-1; slices are addressed by absolute row.
      const auto* floats = static_cast<const float*>(w.rows(y0, y1));
      const char* strip = reinterpret_cast<const char*>(floats);
      if (type == Imf::HALF) {
        halves.assign(floats, floats + size_t(y1 - y0) * size_t(w.width) * size_t(w.channels));
        strip = reinterpret_cast<const char*>(halves.data());
      }
      char* base = const_cast<char*>(strip) - ptrdiff_t(y0) * ptrdiff_t(row);
      Imf::FrameBuffer fb;
      for (int c = 0; c < w.channels; ++c)
        fb.insert(ChannelName(c, w.channels), Imf::Slice(type, base + bytes * size_t(c), px, row));
      out.setFrameBuffer(fb);
      out.writePixels(y1 - y0);
    }
    return true;
  } catch (const std::exception& e) {
    *error = e.what();
    return false;
  }
}

}  // namespace matfit::codec
