// File names of angle-named BTF layouts.
//   Bonn UBO2003: "NNNNN tlAAA plBBB tvCCC pvDDD.jpg" (integer degrees; index unreliable)
//   UTIA:         "tl000_pl000_tv000_pv000.png"       (degrees, decimals allowed)
#pragma once

#include <string>

namespace matfit {

struct BtfName {
  int index = -1;                                         // Bonn only; not used for ordering
  double theta_l = 0, phi_l = 0, theta_v = 0, phi_v = 0;  // degrees
};

bool ParseBonnName(const std::string& filename, BtfName* out);
bool ParseUtiaName(const std::string& filename, BtfName* out);

// Inverse of the parsers; angles are rounded to integer degrees (Bonn) or written with up to
// 3 decimals (UTIA, trailing zeros trimmed, at least 3 integer digits).
std::string MakeBonnName(int index, const BtfName& angles, const std::string& ext);
std::string MakeUtiaName(const BtfName& angles, const std::string& ext);
// Folder of one view in the Bonn layout: "tv030_pv060".
std::string MakeBonnViewFolder(double theta_v, double phi_v);

// Extensions of the image files datasets may hold, lower case: the formats matfit decodes
// natively and those OpenImageIO reads here (camera RAW through libraw, docs/formats.md).
inline constexpr const char* kImageExtensions[] = {
    ".png", ".jpg", ".jpeg", ".tga", ".tif", ".tiff", ".exr", ".bmp", ".hdr", ".webp", ".ppm",
    ".pgm", ".dng", ".cr2",  ".nef", ".arw", ".raf",  ".orf", ".rw2", ".pef", ".srw"};
bool IsImageExtension(const std::string& ext);  // ".png", ".JPG", ".exr", ...

}  // namespace matfit
