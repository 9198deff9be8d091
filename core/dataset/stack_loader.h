// Shared by the readers: decode a list of images into one LightStack, read masks,
// validate light directions.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "core/dataset/dataset.h"
#include "core/image_io.h"
#include "core/light_stack.h"
#include "core/progress.h"

namespace matfit {

// Decodes `files` (in parallel) into a stack with `lights` (same count). Every header is read
// first (no pixel decoded): all images must have the same size and channel count (the first one
// that differs is named), and images × width × height × channels must stay within
// o.max_stack_samples. With o.headers_only nothing is decoded: the stack returned has the size,
// lights and files but no images. 8/16-bit files stay at their depth (the stack's table holds
// the transfer function), float files become float32; files of mixed depth or transfer function
// give a float32 stack. A stack that does not fit in memory is an error naming its size.
// Progress goes to o.progress; files are confined to o.confine_to. With o.crop only that region
// of every image is kept (it must lie inside them). Images with an alpha channel (grey+alpha,
// RGBA) give the mask: a texel is a sample where alpha > half in every such image; an alpha
// opaque everywhere gives no mask, one transparent everywhere is an error.
// stack.mask_source says which.
StatusOr<LightStack> LoadStack(const std::vector<std::string>& files,
                               std::vector<LightSample> lights, const ImageReadOptions& options,
                               const ReadOptions& o);

// Reads a mask image (white = sample): first channel > 0.5 after linearisation. Its size
// must be width × height (the whole images'); with o.crop only that region is returned. Confined to
// o.confine_to like every dataset file; with o.headers_only only its header is checked (the mask
// returned is empty); with o.rows only those rows are returned.
StatusOr<std::vector<uint8_t>> ReadMaskImage(const std::string& path, int width, int height,
                                             const ReadOptions& o);

// Whether `crop` lies inside width × height images (`file` names one for the message).
Status CheckCrop(const CropRect& crop, int width, int height, const std::string& file);

// Reads the mask file `path` (ReadMaskImage at the stack's source size, cropped and banded as
// o says) into stack->mask and records it in mask_source. A mask file wins over the images'
// alpha channel (a warning says so).
Status ApplyMaskFile(const std::string& path, const ReadOptions& o, LightStack* stack);

// Checks a light direction read from `where` (e.g. "lights.txt:3"): finite, non-zero;
// returns the unit vector and fills theta/phi.
StatusOr<LightSample> MakeLight(const Vec3& direction, const std::string& where);

}  // namespace matfit

namespace matfit {
// `.lp` image names (lp_reader.cc). Whether `name` is a path of another system or absolute:
// a Windows drive or UNC path, backslash separators, or a POSIX absolute path.
bool IsForeignPath(const std::string& name);
// The file name part of `name` (after the last '/' or '\\', and a Windows drive's ':').
std::string ForeignBaseName(const std::string& name);
// The image file an `.lp` entry names: the path as written (relative to `base`, the .lp's
// folder; an absolute POSIX path only when not confined), else the base name in `base`
// (*by_base_name true); empty when neither exists.
std::string ResolveLpImage(const std::string& name, const std::filesystem::path& base,
                           const std::string& confine_to, bool* by_base_name);
// Whether the relative `.lp` name lies inside the dataset by name (always, unconfined): only
// then is it looked for as written, or shown in messages.
bool LpNameInside(const std::string& name, const std::filesystem::path& base,
                  const std::string& confine_to);
// Last component of a folder path, ignoring trailing slashes ("a/b/" → "b").
std::string FolderName(const std::string& dir);
// lights.txt in `dir` or its parent folder, or empty. With `confine_to`, the parent folder is
// looked in only when it lies inside that folder (for the server's datasets it never does).
std::string FindLightsTxt(const std::string& dir, const std::string& confine_to = "");
// Whether the parent folder of `dir` holds a lights.txt (for messages).
bool ParentHasLightsTxt(const std::string& dir);
}  // namespace matfit
