// Dataset readers: every multi-light layout users have, each returning a LightStack.
// Layouts (docs/formats.md): Bonn UBO2003 BTF folders, UTIA BTF naming, RTI `.lp`,
// DiLiGenT, and `lights.txt` + numbered images (the UW psm sets).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/color.h"
#include "core/light_stack.h"
#include "core/progress.h"
#include "core/status.h"

namespace matfit {

enum class Layout { kAuto, kBonn, kUtia, kLp, kDiligent, kLightsTxt };

const char* LayoutName(Layout layout);  // "bonn", "utia", "lp", "diligent", "lights-txt"
bool ParseLayout(const std::string& name, Layout* out);
std::vector<std::string> LayoutNames();  // every concrete layout name

struct ViewAngles {
  double theta_deg = 0;  // polar angle of the view direction, [0, 90)
  double phi_deg = 0;    // azimuth, [0, 360)
};

// A region of the images, in pixels of the files: columns [x, x + w), rows [y, y + h).
struct CropRect {
  int x = 0, y = 0, w = 0, h = 0;
};
// "x,y,w,h" (non-negative integers, w and h > 0); false when malformed.
bool ParseCrop(const std::string& text, CropRect* out);

struct ReadOptions {
  Layout layout = Layout::kAuto;  // kAuto: detect from the folder's contents
  // BTF layouts: which view to load; unset = the most frontal view present.
  std::optional<ViewAngles> view;
  // BTF layouts: every view (`--view all`): one stack of views × lights, each image carrying its
  // view (LightSample::view), ordered by view (θv, φv) then light; the most frontal view is the
  // stack's view_direction. Excludes `view`.
  bool all_views = false;
  ColorSpaceChoice color_space = ColorSpaceChoice::kAuto;  // override of the image rules
  ProgressFn progress;  // called as images are decoded; may be empty
  // When set, every file the dataset names must resolve inside this folder (the server): each is
  // opened through ResolveInDataset (core/path_util.h), symlinks and `..` resolved, and refused
  // with a message naming it relative to the folder. lights.txt is not looked for above it.
  std::string confine_to;
  // The largest stack to decode: images × width × height × channels, judged from the image
  // headers before a pixel is decoded (a decompression bomb is refused, not allocated); 0 = no
  // limit but the memory's. The server sets it (--max-stack-msamples).
  int64_t max_stack_samples = 0;
  // Check only (the server's submission check): list and confine every file, parse the light
  // files, read the image and mask headers and apply max_stack_samples, decode no pixel. The
  // stack returned has the size, lights and image files but no images (num_images() == 0).
  bool headers_only = false;
  // Only rows [row0, row0 + rows) of every image and mask (rows 0: all): a rank's band of a
  // distributed fit. The stack holds those rows; its band records where they lie.
  int row0 = 0, rows = 0;
  // Only this region of every image and mask (--crop); it must lie inside the images. Bands
  // (row0, rows) count rows of the region.
  std::optional<CropRect> crop;
  // Ignore light_positions.txt (near lights): every light is distant, along its nominal
  // direction (--distant-lights).
  bool distant_lights = false;
  // Integer stacks: take the stack diagnosis's texels as each image is decoded
  // (LightStack::probe, core/stack_probe.h). `matfit fit --decode-only` turns it off: it times
  // the decode alone.
  bool diagnosis_probe = true;

  bool Check(std::string* why) const;
};

// Which layout `path` (a folder, or a `.lp` file) is in, with the evidence in *reason.
// confine_to: as ReadOptions::confine_to (no lights.txt from outside it; messages name no
// server path).
StatusOr<Layout> DetectLayout(const std::string& path, std::string* reason,
                              const std::string& confine_to = "");

// Reads a dataset. Errors name the file (and line) that was wrong and what would fix it.
StatusOr<LightStack> ReadDataset(const std::string& path, const ReadOptions& options = {});

// Per-layout readers (ReadDataset dispatches to these).
StatusOr<LightStack> ReadBtfFolder(const std::string& dir, Layout layout, const ReadOptions& o);
StatusOr<LightStack> ReadLp(const std::string& path, const ReadOptions& o);
StatusOr<LightStack> ReadDiligent(const std::string& dir, const ReadOptions& o);
StatusOr<LightStack> ReadLightsTxt(const std::string& dir, const ReadOptions& o);

}  // namespace matfit
