#include <cstdlib>

#include "mpi/session.h"

namespace matfit::mpi {

bool LaunchedByMpi() {
  // OpenMPI's mpirun, PMIx (OpenMPI 4, srun --mpi=pmix) and PMI-2 (srun --mpi=pmi2, MPICH).
  for (const char* v : {"OMPI_COMM_WORLD_SIZE", "PMIX_RANK", "PMI_RANK"})
    if (std::getenv(v)) return true;
  return false;
}

}  // namespace matfit::mpi
