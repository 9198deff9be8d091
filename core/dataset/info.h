// `matfit info`: what a dataset holds and what is wrong with it (computed, no I/O).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "core/light_stack.h"

namespace matfit {

struct ThetaGroup {
  int theta_deg = 0;  // nominal θ_l of the group (nearest multiple of 15°)
  int count = 0;
};

struct DatasetInfo {
  std::string layout, detection_reason, source, object_name;
  int images = 0, width = 0, height = 0, channels = 0;
  size_t memory_bytes = 0;  // LightStack::MemoryBytes (samples at their stored size)
  std::string sample_type;  // how the stack holds samples: "uint8", "uint16", "float32"
  // The tone curve the stack itself suggests (fit/diagnostics.h DescribeToneCurve; filled by
  // `matfit info`, empty when not estimated) and its verdict name.
  std::string tone_curve, tone_verdict;
  double view_theta_deg = 0, view_phi_deg = 0;
  // Multi-view stacks (--view all): the number of views and their θv range (views 1: one view).
  int views = 1;
  double view_theta_min = 0, view_theta_max = 0;
  std::vector<ThetaGroup> theta_groups;  // light count per θ_l group
  double theta_min = 0, theta_max = 0, max_azimuth_gap_deg = 0;
  double singular_values[3] = {0, 0, 0};  // of the N × 3 light matrix, descending
  double condition_number = 0;            // σ1 / σ3 (inf when rank < 3)
  int rank = 0;                           // numerical rank of the light matrix
  Vec3 mean_light;                        // mean light direction
  double intensity_min = 0, intensity_max = 0;
  // Near lights (light_positions.txt): their distance from the image centre (source pixels) and
  // the widest spread of one light's direction over the texels (degrees). near_lights false:
  // distant lights.
  bool near_lights = false;
  double near_distance_min = 0, near_distance_max = 0, near_direction_spread_deg = 0;
  std::vector<std::string> encodings;  // "sRGB (8-bit default (sRGB)) × 12"
  int64_t masked_texels = 0;           // texels inside the mask
  bool has_mask = false;
  std::string mask_source;  // LightStack::mask_source
  // --crop: the region of the source images the stack holds (cropped false: all of them).
  bool cropped = false;
  int crop_x = 0, crop_y = 0, source_width = 0, source_height = 0;
  double saturated_fraction = 0;  // of all pixels of all images
  std::string worst_saturated_file;
  double worst_saturated_fraction = 0;
  int64_t nonfinite_samples = 0;
  std::vector<std::string> warnings;
};

DatasetInfo ComputeDatasetInfo(const LightStack& stack);
// How the images were linearised, one entry per distinct encoding: "sRGB (8-bit default (sRGB))
// x 12", joined by "; ".
std::string DescribeReadEncoding(const LightStack& stack);
std::string FormatDatasetInfo(const DatasetInfo& info);  // human-readable report
std::string DatasetInfoJson(const DatasetInfo& info);    // the same as JSON

}  // namespace matfit
