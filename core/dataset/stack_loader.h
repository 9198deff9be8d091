// Shared by the readers: decode a list of images into one LightStack, read masks,
// validate light directions.
#pragma once

#include <cstdint>
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
// Progress goes to o.progress; files are confined to o.confine_to.
StatusOr<LightStack> LoadStack(const std::vector<std::string>& files,
                               std::vector<LightSample> lights, const ImageReadOptions& options,
                               const ReadOptions& o);

// Reads a mask image (white = sample): first channel > 0.5 after linearisation. Its size
// must be width × height (the whole images'). Confined to o.confine_to like every dataset file;
// with o.headers_only only its header is checked (the mask returned is empty); with o.rows only
// those rows are returned.
StatusOr<std::vector<uint8_t>> ReadMaskImage(const std::string& path, int width, int height,
                                             const ReadOptions& o);

// Checks a light direction read from `where` (e.g. "lights.txt:3"): finite, non-zero;
// returns the unit vector and fills theta/phi.
StatusOr<LightSample> MakeLight(const Vec3& direction, const std::string& where);

}  // namespace matfit

namespace matfit {
// Last component of a folder path, ignoring trailing slashes ("a/b/" → "b").
std::string FolderName(const std::string& dir);
// lights.txt in `dir` or its parent folder, or empty. With `confine_to`, the parent folder is
// looked in only when it lies inside that folder (for the server's datasets it never does).
std::string FindLightsTxt(const std::string& dir, const std::string& confine_to = "");
// Whether the parent folder of `dir` holds a lights.txt (for messages).
bool ParentHasLightsTxt(const std::string& dir);
}  // namespace matfit
