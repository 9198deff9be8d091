#include "fit/bands.h"

#include <algorithm>
#include <numeric>
#include <string>

#include "core/check.h"
#include "core/comm.h"
#include "core/material_maps.h"
#include "core/model/model.h"

namespace matfit::fit {

StatusOr<RowBand> SplitRows(int width, int height, int rank, int ranks, int multiple) {
  if (ranks < 1 || rank < 0 || rank >= ranks || width < 1 || multiple < 1)
    return InvalidArgument("band " + std::to_string(rank) + " of " + std::to_string(ranks));
  if (height / multiple < ranks)
    return InvalidArgument(
        "the images have " + std::to_string(height) + " rows but " + std::to_string(ranks) +
        " ranks were started: run with at most one rank per " +
        (multiple == 1 ? std::string("row")
                       : std::to_string(multiple) + " rows (model selection's coarsest mip)") +
        ", i.e. at most " + std::to_string(height / multiple) + " ranks");
  // Rows per unit: the fewest whose texels fill whole runs (width · g ≡ 0 mod kEvalRun), and a
  // multiple of `multiple`; just `multiple` when that is too coarse for this many ranks.
  const int g = kEvalRun / std::gcd(width, kEvalRun);
  int unit = std::lcm(g, multiple);
  if (height / unit < ranks) unit = multiple;
  const int64_t units = height / unit;  // the rows of an incomplete unit go to the last band
  const auto start = [&](int r) { return int(units * r / ranks * unit); };
  RowBand b;
  b.row0 = start(rank);
  b.rows = (rank + 1 == ranks ? height : start(rank + 1)) - b.row0;
  return b;
}

void GatherPlane(const Comm& comm, std::vector<float>* v) { *v = ConcatAcross(comm, *v, 0); }
void GatherPlane(const Comm& comm, std::vector<uint8_t>* v) { *v = ConcatAcross(comm, *v, 0); }
void GatherPlane(const Comm& comm, std::vector<uint16_t>* v) { *v = ConcatAcross(comm, *v, 0); }

void GatherMaps(const Comm& comm, int full_height, MaterialMaps* m) {
  const int width = m->width, rows = m->height;
  for (Image* img : {&m->normal, &m->albedo, &m->height_map, &m->specular, &m->exponent,
                     &m->roughness, &m->thickness, &m->translucency, &m->albedo_back, &m->hl2,
                     &m->mask, &m->ambient, &m->normal_scale, &m->specular_color, &m->coefficients,
                     &m->interpolation_error, &m->lobe_shape}) {
    // Every band has the same maps (one model, one set of lights).
    if (img->width() != width || img->height() != rows || img->channels() == 0) continue;
    Image whole = comm.rank() == 0 ? Image(width, full_height, img->channels()) : Image();
    for (int c = 0; c < img->channels(); ++c) {
      const auto plane = img->Plane(c);
      const std::vector<float> all =
          ConcatAcross(comm, std::vector<float>(plane.begin(), plane.end()), 0);
      if (comm.rank() != 0) continue;
      MATFIT_CHECK(int64_t(all.size()) == whole.plane_size(), "GatherMaps: bands of other sizes");
      std::copy(all.begin(), all.end(), whole.Plane(c).begin());
    }
    if (comm.rank() == 0) *img = std::move(whole);
  }
  if (comm.rank() == 0) m->height = full_height;
}

}  // namespace matfit::fit
