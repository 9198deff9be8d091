// A fit distributed over MPI ranks (docs/scale-out.md): how the rows are split into bands, and
// how rank 0 collects the bands' per-texel results into the whole stack's.
#pragma once

#include <cstdint>
#include <vector>

#include "core/status.h"

namespace matfit {
class Comm;
struct MaterialMaps;
}  // namespace matfit

namespace matfit::fit {

struct RowBand {
  int row0 = 0, rows = 0;
};

// Band `rank` of `ranks` over an image of width × height: contiguous rows, as even as the
// granularity allows, every band but the last a multiple of `multiple` rows (model selection's
// mip blocks, fit/select.h). Bands also start on a boundary of the batched evaluation's texel
// runs (kEvalRun texels) when every band can still get rows, so that the bands' run sums are
// the whole stack's, bit for bit. An error when there are fewer row blocks than ranks.
StatusOr<RowBand> SplitRows(int width, int height, int rank, int ranks, int multiple = 1);

// Collectives over `comm` (every rank calls them): rank 0's vector becomes every band's values in
// rank order (the whole stack's, row-major); the other ranks' vectors are left empty.
void GatherPlane(const Comm& comm, std::vector<float>* v);
void GatherPlane(const Comm& comm, std::vector<uint8_t>* v);
void GatherPlane(const Comm& comm, std::vector<uint16_t>* v);
// The same for every texel-sized map of `maps` (rbf's basis table is not one); rank 0's maps
// become full_height rows high, the other ranks' are left as they were.
void GatherMaps(const Comm& comm, int full_height, MaterialMaps* maps);

}  // namespace matfit::fit
